"""Stage 1, the truth source: ground-truth motion of each follower→leader pair, one
:class:`~acc_fusion.truth.frame.TruthFrame` per step, from scripted manoeuvres, SUMO, highway-env
or recorded traffic; the driver model that closes the loop lives here too.
"""
