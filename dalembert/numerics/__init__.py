"""Numerical building blocks shared by dynamics, statics and multibody models.

Neutral ground below every layer that uses them: a rank test with one threshold
(:mod:`.rank`) and one Gauss-Newton projection onto ``psi(q) = 0``
(:mod:`.gauss_newton`). Nothing here imports from the solvers, statics or
multibody packages.
"""
