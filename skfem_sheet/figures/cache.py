"""The figures' cached tables: read when they are there, else computed and written atomically.

One helper, :func:`cached`, for every cache a figure keeps besides the fold
map (which :func:`skfem_sheet.studies.foldmap.fold_map` journals itself):
fig3's deformed surfaces (``.npz``), fig5's and fig6's ribbon curves
(``.csv``).  Files are written through :func:`skfem_sheet.io.atomic_write`,
so an interrupted run never leaves half a table behind.

Examples
--------
>>> import tempfile
>>> folder = data_folder(tempfile.mkdtemp())
>>> calls = []
>>> def compute():
...     calls.append(1)
...     return pd.DataFrame({"x": [1.0, float("nan")]})
>>> fn = os.path.join(folder, "t.csv")
>>> cached(fn, compute)["x"].tolist(), cached(fn, compute)["x"].tolist()[0], len(calls)
([1.0, nan], 1.0, 1)
"""
from __future__ import annotations

import io
import os

import numpy as np
import pandas as pd

from ..io import atomic_write
from ..params import ParameterError

__all__ = ["data_folder", "cached", "load_or_compute"]

_SUFFIXES = (".csv", ".npz")


def data_folder(data_dir, *sub) -> str:
    """The folder ``data_dir`` (or ``data_dir/sub...``), created if needed.

    Raises
    ------
    ParameterError
        Naming ``data_dir`` if the folder cannot be made.

    Examples
    --------
    >>> import tempfile
    >>> os.path.isdir(data_folder(tempfile.mkdtemp(), "fig3-quick"))
    True
    """
    data_dir = os.fspath(data_dir)
    folder = os.path.join(data_dir, *sub)
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as err:
        raise ParameterError(f"data_dir must be a writable folder, got {data_dir!r} ({err})") \
            from None
    return folder


def _read(path):
    if path.endswith(".csv"):
        return pd.read_csv(path)
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _encode(path, data) -> bytes | str:
    if path.endswith(".csv"):
        if not isinstance(data, pd.DataFrame):
            raise ParameterError(f"path {path!r}: a .csv cache holds a DataFrame, "
                                 f"got {type(data).__name__}")
        return data.to_csv(index=False)
    buf = io.BytesIO()
    np.savez_compressed(buf, **data)
    return buf.getvalue()


def cached(path, compute, accept=None):
    """The table at ``path`` if there (and ``accept(table)``), else ``compute()``, written there.

    Parameters
    ----------
    path : str
        ``.csv`` (a :class:`pandas.DataFrame`, written without its index) or
        ``.npz`` (a dict of arrays, compressed; read back as a dict of arrays).
    compute : callable
        ``() -> table``, called only when the file is missing or not accepted.
    accept : callable, optional
        ``table -> bool``: whether a table read from ``path`` is the one
        wanted (e.g. on the right grid); default: any table is.

    Returns
    -------
    DataFrame or dict
        The table read from ``path``, or the one computed (as ``compute``
        returned it) after writing it atomically
        (:func:`skfem_sheet.io.atomic_write`).
    """
    return load_or_compute(path, compute, accept)[0]


def load_or_compute(path, compute, accept=None):
    """:func:`cached`, and whether the table was computed now: ``(table, computed)``.

    Examples
    --------
    >>> import tempfile
    >>> fn = os.path.join(tempfile.mkdtemp(), "t.csv")
    >>> make = lambda: pd.DataFrame({"x": [1.0]})
    >>> load_or_compute(fn, make)[1], load_or_compute(fn, make)[1]
    (True, False)
    """
    path = os.fspath(path)
    if not path.endswith(_SUFFIXES):
        raise ParameterError(f"path must end with {' or '.join(_SUFFIXES)}, got {path!r}")
    if os.path.exists(path):
        data = _read(path)
        if accept is None or accept(data):
            return data, False
    data = compute()
    atomic_write(path, _encode(path, data))
    return data, True
