"""The package version (layer 0: anything may import it; ``skfem_sheet.__version__``)."""

__version__ = "0.1.0"
