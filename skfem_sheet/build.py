"""The build chain of a discrete sheet, owned by the solve or study that uses it.

A discrete problem is built in four steps (the data path of
``docs/architecture.md``): the mesh (:class:`~skfem_sheet.mesh.MeshSpec`:
gmsh triangulates the plan, which is extruded), its Taylor-Hood space
(:class:`~skfem_sheet.discretisation.TaylorHoodSpace`: bases, quadrature
arrays, dof layout), the assembler of that space
(:class:`~skfem_sheet.assembly.Assembler`: sparsity pattern, assembly
operators, work buffers and element threads) and the problem
(:class:`~skfem_sheet.problem.SheetProblem`: the sheet on them).  The first
three cost time and memory; the problem is a few references (its constant
blocks are made on first use); ``docs/decisions.md``, "Keeping the build".

:class:`BuildChain` keeps what it built so that a second request for the
same mesh (the other load path of the same sheet, another curvature or
modulus, the coarse mesh of the next solve) does not build it again -- for
as long as its holder keeps it, and nobody else: nothing in the package is
cached at module level.  A solve makes a chain of its own when it is not
given one (:func:`skfem_sheet.solve.solve`), so its meshes are freed with
it (save the problem its :class:`~skfem_sheet.result.Result` holds); a study
that solves many sheets on few meshes passes one chain to every solve.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass, field

from .assembly import Assembler
from .discretisation import TaylorHoodSpace
from .mesh import MeshSpec, SheetMesh
from .params import ParameterError, Sheet, check_integer
from .problem import SheetProblem

__all__ = ["BuildChain"]


class _Entry:
    """One mesh of a chain, with its spaces and assemblers by quadrature order."""

    __slots__ = ("mesh", "spaces", "assemblers")

    def __init__(self, mesh):
        self.mesh, self.spaces, self.assemblers = mesh, {}, {}


@dataclass(frozen=True, eq=False)
class BuildChain:
    """The meshes, spaces and assemblers of one solve or one study.

    Parameters
    ----------
    max_meshes : int
        The bound: at most this many meshes are kept, each with its spaces
        (one per quadrature order asked for) and their assemblers; asking
        for another drops the one used least recently, with its space and
        assembler (0: nothing is kept, everything is built afresh).  A solve
        uses two meshes (the coarse start's and its own); the default keeps
        those of two sheets.  One kept mesh holds about 250 MB at hmax 0.03
        (half rectangle L/a 1.3, once assembled), 25 MB at hmax 0.1.

    Problems are not kept: :meth:`problem` makes a new one on the kept space
    and assembler every time.

    Examples
    --------
    >>> chain = BuildChain(max_meshes=2)
    >>> a = chain.problem(Sheet(length=0.5, curvature=1.0), 0.2, half=True)
    >>> b = chain.problem(Sheet(length=0.5, curvature=3.0), 0.2, half=True)
    >>> a is b, a.space is b.space, a.assembler is b.assembler, len(chain)
    (False, True, True, 1)
    >>> _ = chain.mesh(Sheet(length=0.6), 0.2), chain.mesh(Sheet(length=0.7), 0.2)
    >>> len(chain), chain.space(a.sheet_mesh) is a.space  # a's mesh dropped: rebuilt
    (2, False)
    """

    max_meshes: int = 4
    _entries: OrderedDict = field(default_factory=OrderedDict, init=False, repr=False)
    _lock: threading.RLock = field(default_factory=threading.RLock, init=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "max_meshes", check_integer("max_meshes", self.max_meshes, 0))

    def __len__(self) -> int:
        """The number of meshes kept."""
        return len(self._entries)

    def __reduce__(self):  # a chain travels empty (to a worker process)
        return (BuildChain, (self.max_meshes,))

    def clear(self) -> None:
        """Drop every mesh kept (and its spaces and assemblers)."""
        with self._lock:
            self._entries.clear()

    def _entry_of(self, mesh):
        for entry in self._entries.values():
            if entry.mesh is mesh:
                return entry
        return None

    def mesh(self, sheet: Sheet, hmax: float, layers=None, half: bool = False,
             refine: int = 0) -> SheetMesh:
        """The mesh of :func:`~skfem_sheet.mesh.sheet_mesh` with these
        arguments: the one kept if there is one, else built (and kept)."""
        spec = MeshSpec.of(sheet, hmax, layers, half, refine)
        with self._lock:
            entry = self._entries.get(spec)
            if entry is not None:
                self._entries.move_to_end(spec)
                return entry.mesh
        mesh = spec.build()
        if self.max_meshes == 0:
            return mesh
        with self._lock:
            entry = self._entries.get(spec)  # built meanwhile by another thread
            if entry is None:
                entry = self._entries[spec] = _Entry(mesh)
                while len(self._entries) > self.max_meshes:
                    self._entries.popitem(last=False)
            return entry.mesh

    def space(self, mesh: SheetMesh, quadrature_order: int = 2) -> TaylorHoodSpace:
        """The Taylor-Hood space of ``mesh`` (kept with the mesh if this chain
        keeps it; built afresh, not kept, for another mesh)."""
        with self._lock:
            entry = self._entry_of(mesh)
            if entry is None:
                return TaylorHoodSpace.build(mesh, quadrature_order)
            space = entry.spaces.get(quadrature_order)
            if space is None:
                space = entry.spaces[quadrature_order] = TaylorHoodSpace.build(
                    mesh, quadrature_order)
            return space

    def assembler(self, space: TaylorHoodSpace) -> Assembler:
        """The assembler of ``space``'s dof layout (of its unstretched space;
        kept with the mesh if this chain keeps it)."""
        space = space if space.reference is None else space.reference
        with self._lock:
            entry = self._entry_of(space.mesh)
            if entry is None or entry.spaces.get(space.quadrature_order) is not space:
                return Assembler.build(space)
            assembler = entry.assemblers.get(space.quadrature_order)
            if assembler is None:
                assembler = entry.assemblers[space.quadrature_order] = Assembler.build(space)
            return assembler

    def problem(self, sheet: Sheet, hmax: float, layers=None, quadrature_order: int = 2,
                half: bool = False, refine: int = 0) -> SheetProblem:
        """``sheet`` on its mesh (the arguments of
        :func:`~skfem_sheet.mesh.sheet_mesh`), on the kept space and assembler."""
        if not isinstance(sheet, Sheet):
            raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
        mesh = self.mesh(sheet, hmax, layers, half, refine)
        space = self.space(mesh, quadrature_order)
        return SheetProblem(sheet, mesh, quadrature_order, space=space,
                            assembler=self.assembler(space))
