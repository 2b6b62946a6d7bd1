"""Running a simulation: its plan (:mod:`.plan`), the segment driver (:mod:`.segments`)
and sampled inputs on it (:mod:`.sampled`), the loops (:mod:`.loop`) and their
SciPy-like door (:mod:`.integrate`), and what a run says about values that are not
finite (:mod:`.nonfinite`)."""
