"""Stage 4, the fusion center: the federated filter (Carlson), its fault detection and isolation,
and the baselines it is judged against (single sensor, centralized).
"""
