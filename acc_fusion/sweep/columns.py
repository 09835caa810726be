"""The columns of a sweep's rows: identifiers, event counts and summed exposure."""

from __future__ import annotations

from acc_fusion.metrics.events import COUNTS
from acc_fusion.metrics.summary import CAUSE_COUNTS

#: Event counts of a row (see :meth:`acc_fusion.metrics.events.FCWMetrics.per_pair`): the
#: events, then the nuisance and sensing-false warnings by cause (zeros but in the 2-D world).
COUNT_COLUMNS = (*COUNTS, *CAUSE_COUNTS)


#: Exposure and lead-time columns of a row.
SUM_COLUMNS = ("hours", "km", "lead_time_sum_s")


#: Columns of every row before the axes' columns.
ID_COLUMNS = ("run_id", "point_id", "chunk_id", "seed", "run")
