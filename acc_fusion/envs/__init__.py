"""Gymnasium environments of acc_fusion, installed as ``acc_fusion.envs``.

The top-level ``envs/`` folder of the repository is mapped into the package by
``pyproject.toml`` (``package-dir``), so it works the same from a checkout and after a
non-editable ``pip install .``.
"""
