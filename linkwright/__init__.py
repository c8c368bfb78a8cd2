"""linkwright — the application: command line, study files, reports and benchmarks.

The libraries are the top-level packages ``closure`` (the engine),
``synthesis``, ``stiffness`` and ``approx``.
"""
__version__ = "0.1.0"
