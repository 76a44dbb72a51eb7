"""Studies: many solves as one resumable, parallel job (runner, sweep, fold map).

Layer 13: uses ``solve`` and ``bistability``; used by figures and the CLI.
"""
