"""highway-env as a truth source."""
