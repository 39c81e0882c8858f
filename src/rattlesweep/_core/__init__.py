"""Numba kernels: plain float and array functions, no Python objects.

Where things live:

* ``workspace`` – the block workspace every model shares: ``BLOCK``, the accessor
  ``at(region, row, j)``, the shared rows (contact outputs, switching state, time-loop
  bookkeeping, common parameters, observables), status codes and method numbers;
* ``rows`` – the declarative row tables (name, units, long name, packing) every layout
  is built from;
* ``stepper`` – the one time loop and its entry points, for every model and friction
  level (``workspace.ROLLING``, ``SLIDING``, ``COUPLES``: what a copy compiles);
* ``levels`` – which right-hand side variant each evaluation runs at each friction level,
  and the switching a level needs;
* ``reversals`` – the spin's first reversal and the heading's reversals, observed once
  per step;
* ``switching`` – the Coulomb stick/slip decisions (docs/model.md: dynamics);
* ``events`` – the scalar path that redoes a lane's step with its switches located;
* ``stages`` – the RK4 stage arithmetic fused into each model's derivative loop;
* ``models`` – the hooks the stepper calls, chosen per model at compile time;
* ``rattleback/`` – the 3-D model: ``layout`` (its rows), ``geometry`` (contact
  geometry, impulses; docs/model.md: contact geometry), ``dynamics`` (the right-hand side,
  ``eval_block``) with its phases ``contact`` (kinematics, slip velocity), ``slip`` (the
  friction direction; ``consistent`` solves for a slow slip's), ``accelerations`` (with
  the couples) and ``derivative`` (friction force, stage arithmetic), ``model`` (what it
  supplies to the stepper);
* ``planar/`` – the rocking semi-ellipse of docs/model.md: the planar rocking semi-ellipse,
  with the same modules;
* ``jit`` – the compile policy every kernel uses, and the locked on-disk cache;
* ``specialisations`` – every compiled variant the library calls, as the jobs
  ``rattlesweep compile`` builds.
"""
