"""Singular configurations during a run: careful steps that leave the combinations
of rows losing rank out (:mod:`.careful`), and the watch that names a configuration
where the steps collapse (:mod:`.watch`)."""
