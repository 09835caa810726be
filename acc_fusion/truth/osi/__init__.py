"""ASAM OSI (Open Simulation Interface, 3.8) ground truth in and out: the 2-D world's object
frames as ``osi3.GroundTruth`` messages (:mod:`~acc_fusion.truth.osi.ground_truth`), OSI trace
files written atomically (:mod:`~acc_fusion.truth.osi.trace`), and any producer's
GroundTruth or SensorView trace read back as a truth source
(:mod:`~acc_fusion.truth.osi.source`).  The conventions both directions share — ids, lanes,
this project's extension, the mapping of kinds — are :mod:`~acc_fusion.truth.osi.convention`.

Needs the ``interop`` extra (``pip install 'acc_fusion[interop]'``: ``osi-python``,
``asam-osi-utilities``), imported only when a message is made or a trace is opened.
"""
