"""Recorded traffic as truth: readers of highD, NGSIM and mapped trajectory CSV files, the
follower→leader pairs of a recording, and :class:`~acc_fusion.truth.replay.source.ReplaySource`,
which replays them through the FCW pipeline (open loop only).  ASAM OSI traces (format
``osi``) are read by :mod:`acc_fusion.truth.osi`."""

#: The formats a recording can have (here, so that the command line's parser reads them
#: without importing the readers).
FORMATS = ("highd", "ngsim", "csv", "osi")
#: What to do with a recorded row outside the physical bounds: refuse the recording, or drop it.
BAD_ROWS = ("refuse", "drop")
