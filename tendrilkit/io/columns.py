"""Tables read as rows of cells and written from columns, without pandas: the ``fit`` command's reader and writer.

:func:`read_rows` reads a CSV's header and cells; :func:`write_columns` writes the same bytes as :func:`tendrilkit.io.write_result` (pandas' ``to_csv`` with
:data:`tendrilkit.io.FLOAT_FORMAT`), atomically; the ``fit`` command reads and
writes its tables without importing pandas (its import was a tenth of the
command's time).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from tendrilkit.exceptions import ExperimentError
from tendrilkit.io import _check_columns, atomic_path
from tendrilkit.schema import Table

__all__ = ["read_rows", "write_columns"]


def write_columns(columns: dict, path: str | Path, table: Table) -> None:
    """Write a result table given as columns, atomically, the same bytes as :func:`write_result` (no pandas).

    Parameters
    ----------
    columns : dict of column name -> (m,) array or list
        Exactly ``table.columns``, in that order, all of one length. By the
        column's kind (:mod:`tendrilkit.schema`): ``int`` integers; ``Int``
        integers or NaN (missing: empty); ``float`` floats, NaN empty, others
        in the shortest text that reads back as the same double (numpy's,
        as pandas writes them); ``str`` text (quoted as the ``csv`` module
        does when needed).
    path : path of the CSV file
    table : :class:`tendrilkit.schema.Table`

    Raises
    ------
    ValueError
        When the columns differ from the schema's, or their lengths differ.
    """
    _check_columns(tuple(map(str, columns)), table)
    cells = []
    for name, kind in zip(table.columns, table.kinds):
        v = columns[name]
        if kind == "float":
            # Python's repr: the shortest text that reads back as the same double, as numpy's (the
            # same text, checked on 400000 doubles over the whole range), in two thirds of the time
            a = np.asarray(v, dtype=float)
            text = list(map(repr, a.tolist()))
            for i in np.flatnonzero(np.isnan(a)).tolist():
                text[i] = ""
        elif kind == "Int":
            a = np.asarray(v, dtype=float)
            text = np.array(["" if np.isnan(x) else str(int(x)) for x in a], dtype=object)
        elif kind in ("int", "bool"):
            text = np.asarray(v).astype(str).astype(object)
        else:
            text = np.array(["" if x is None or (isinstance(x, float) and np.isnan(x)) else str(x) for x in v],
                            dtype=object)
        cells.append(text)
    if len({len(c) for c in cells}) > 1:
        raise ValueError(f"{table.name}: columns of different lengths {[len(c) for c in cells]}")
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(table.columns)
            if len(cells) > 1 and all(kind != "str" for kind in table.kinds):
                # numbers' cells (repr, str of an int, True/False, or empty) hold no comma, quote or line
                # break, and a row of several cells is quoted only for those: csv's bytes, joined without
                # its per-cell search for them (a third of the time of pwc_curves' 120000 cells)
                fh.writelines([",".join(row) + "\n" for row in zip(*cells)])
            else:
                w.writerows(zip(*cells))


def read_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    """A CSV file's header and rows of cells, without pandas (blank lines skipped, as pandas does).

    Raises
    ------
    ExperimentError
        One line naming the file: it cannot be read as CSV, is empty, or a row
        has more fields than the header.
    """
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [r for r in csv.reader(fh) if r]  # blank lines skipped, as pandas does
    except (csv.Error, UnicodeDecodeError, OSError) as e:
        raise ExperimentError(f"{path}: cannot read as CSV ({type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''})") from None
    if not rows:
        raise ExperimentError(f"{path}: cannot read as CSV (no columns in the file)")
    header, body = rows[0], rows[1:]
    for i, r in enumerate(body):
        if len(r) > len(header):
            raise ExperimentError(f"{path}: cannot read as CSV (expected {len(header)} fields in line {i + 2}, "
                                  f"saw {len(r)})")
    return header, body
