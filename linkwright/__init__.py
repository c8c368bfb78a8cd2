"""linkwright — the application: command line, study files, reports and benchmarks.

The libraries are the top-level packages ``closure`` (the engine),
``synthesis``, ``stiffness`` and ``approx``.  :mod:`linkwright.render` is the one
rendering layer of every report and plot (Markdown, HTML, figures, numbers with their
units); the libraries' report and plot functions (``stiffness.report``,
``stiffness.plot_map``) call it lazily.
"""
__version__ = "0.1.0"


def __getattr__(name):
    # run_study imports pandas/Dask machinery only when first used
    if name == "run_study":
        from .distributed import run_study
        return run_study
    raise AttributeError(f"module 'linkwright' has no attribute {name!r}")
