"""Stage 2, sensors: radar and infrared measurement models with noise, limits, clutter and
faults.
"""
