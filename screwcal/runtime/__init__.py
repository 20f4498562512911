"""The process's own settings (BLAS threads, the C heap's thresholds, the garbage collector's
pace), decided by its doors: `policy` says which door sets which (`blas_threads`, `heap`: how).

May import: nothing of ours (a floor of its own, like `rapid`): every package's door (the command
line, the service, a study's workers) applies it before it loads anything else, numpy included.
"""

__all__: list[str] = []  # the doors import `screwcal.runtime.policy`
