"""The peers' side of benchmarks/bench_peers.py: rattlesweep's body and launches as a
MuJoCo model (mujoco_rattleback) and its rolling equations as JAX programs
(jax_rolling). Each imports its peer only when called."""
