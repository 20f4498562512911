"""The command line: the `screwcal` console script (`main`) and the core's offline subcommands
(calibrate, compensate, align, predict, evaluate, testcube, study, simulate).

The top of the house: the only part of `screwcal` that may import `service` or `simulators`
(their subcommands are registered here). Each command module imports its numeric code inside
`run`, so that `screwcal --help` and each subcommand import only what they use.
"""
