"""skfem_sheet: curvature-induced rigidity of a clamped, sagging elastic sheet."""
from .params import Sheet

__version__ = "0.1.0"
__all__ = ["Sheet", "__version__"]
