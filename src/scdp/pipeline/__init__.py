"""``scdp reproduce``: the paper's pipeline as resumable stages (``stages``), the report files
written after them (``report``), and the run that ties them together (``run``)."""
