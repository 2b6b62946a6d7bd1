"""The KKT system of constrained dynamics: the dense solve and its diagnosis
(:mod:`.dense`), the sparse solver on the model's pattern (:mod:`.sparse`), the solve
with nearly dependent combinations of rows left out (:mod:`.truncated`), and the one
factorization object behind them (:mod:`.factorization`)."""
