"""The ``acc-fusion`` command line: one module per command."""
