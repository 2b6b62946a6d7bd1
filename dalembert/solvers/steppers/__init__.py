"""Steppers: one step of an integration method, and the control of its size.

The contract, in the style of diffrax's solvers and controllers, with the state of
each passed in and out explicitly (nothing hidden in a solver object):

- a **stepper** takes one attempt from ``(t, y, f = y'(t))`` with a given signed step
  ``h`` and returns an :class:`~.runge_kutta.Attempt`: the state and derivative at
  ``t + h``, the stages, and its error norm against a scale
  (``atol + rtol max(|y|, |y_new|)``); from an accepted attempt it gives the step's
  interpolant (:meth:`~.runge_kutta.ExplicitRungeKutta.interpolant`);
- a **controller** (:class:`~.controller.PIController`) is a frozen value; its state
  (:class:`~.controller.ControllerState`) is what it remembers between steps. From an
  attempt's error it says whether to accept and the next step size, returning the new
  state;
- :func:`~.runge_kutta.controlled_step` is the one loop that joins them: attempts,
  shrinking the step after each rejection, until one is accepted or the step would be
  too small.

The controller is defined once: the C runtime's steps read its constants from the
same value (:mod:`dalembert.solvers.native.runge_kutta`).
"""
