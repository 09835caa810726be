"""Multi-target tracking: per-sensor trackers of the 2-D world, the track-to-track association
across sensors, and the bridge that feeds each associated object to the 1-D federated filter.
"""
