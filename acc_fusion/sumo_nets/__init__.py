"""SUMO networks bundled with acc_fusion (package data; see README.md in this folder)."""
