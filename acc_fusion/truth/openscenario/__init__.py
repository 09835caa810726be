"""OpenSCENARIO XML and OpenDRIVE: the test-track procedures written as scenario files
(:mod:`.export`), scenario files read into the 2-D world's scenes (:mod:`.read`), their road
(:mod:`.road`), ASAM's quality checkers run on them (:mod:`.check`); :mod:`.parameters`,
:mod:`.triggers` and :mod:`.document` serve the reader."""
