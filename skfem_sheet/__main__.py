"""``python -m skfem_sheet``: the command line (:func:`skfem_sheet.cli.main`)."""
import sys

from .cli import main

if __name__ == "__main__":      # (importing this module, as the API reference does, runs nothing)
    sys.exit(main())
