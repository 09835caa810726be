"""Braking after the warning: automatic emergency braking (:mod:`acc_fusion.braking.aeb`)."""
