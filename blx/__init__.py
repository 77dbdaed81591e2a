"""blx: RL-driven behaviour engineering beyond reward maximisation, on JAX and MuJoCo MJX."""

__version__ = "0.1.0"


def __getattr__(name):
  """``blx.load_run(DIR) -> Run(env, objective, params, ...)``, imported on first use."""
  if name == "load_run":
    from blx.experiments.runs import load_run
    return load_run
  raise AttributeError(f"module 'blx' has no attribute {name!r}")
