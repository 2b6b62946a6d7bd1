"""Unilateral constraints in a run: contacts that close, push and open again.

A unilateral constraint ``g(q, t) >= 0`` (:class:`~dalembert.Unilateral`) is a row of
the equations only while it is closed. The event-driven mode runs the smooth motion
between switches in segments, each with the rows closed then
(:mod:`~dalembert.solvers.contact.driver`), and at a switch

- a gap reaching 0 while closing is an impact: the velocities jump by impulses from the
  KKT matrix on the acting rows (:mod:`~dalembert.solvers.contact.laws`), Newton's law
  of restitution giving each contact's rate after;
- a closed contact's multiplier reaching 0 is a separation: the row opens;

and the rows closed after it are those a complementarity problem at the acceleration
level keeps (:func:`~dalembert.solvers.contact.laws.closed_gaps`): every closed
contact pushes, every touching open one does not move into its obstacle.
"""
