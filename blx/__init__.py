"""blx: RL-driven behaviour engineering beyond reward maximisation, on JAX and MuJoCo MJX."""

__version__ = "0.1.0"
