"""Numba kernels: plain float and array functions, no Python objects.

``layout`` names the rows of the structure-of-arrays blocks, ``geometry`` the contact
geometry, ``dynamics`` the stick/slip right-hand side, ``stepper`` the time loop and
its entry points. ``jit`` holds the compile policy every kernel uses.
"""
