"""Snapshot files (VTK XML PolyData, ASCII, as the service writes them) read into numpy arrays."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np


@dataclass
class PolyData:
    """One VTK PolyData piece.

    Attributes:
        points: Point coordinates, m, shape ``(n, 3)`` (z = 0 in 2D).
        point_data: Arrays per point by name (``radius``, ``velocity``, ``force``, ...), shape
            ``(n,)`` or ``(n, components)``.
        cell_data: Arrays per cell by name (the contacts' ``normal_force``, ``force``, ...).
        cells: Cell connectivity by kind (``verts``, ``lines``, ``polys``): a list per cell of
            its point indices.
    """

    points: np.ndarray
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    cell_data: dict[str, np.ndarray] = field(default_factory=dict)
    cells: dict[str, list[np.ndarray]] = field(default_factory=dict)


def _array(e: ET.Element) -> np.ndarray:
    fmt = e.get("format", "ascii")
    if fmt != "ascii":
        raise ValueError(f"DataArray {e.get('Name')!r} is in format {fmt!r}; only ascii is read")
    kind = e.get("type", "Float64")
    dtype = np.int64 if kind.startswith(("Int", "UInt")) else float
    values = np.array((e.text or "").split(), dtype=dtype)
    components = int(e.get("NumberOfComponents", "1"))
    return values.reshape(-1, components) if components > 1 else values


def read_polydata(text: str | bytes) -> PolyData:
    """Parses a VTK XML PolyData file (its first piece).

    Raises:
        ValueError: The text is not VTK PolyData, or its arrays are not ASCII.
    """
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise ValueError(f"not a VTK XML file: {err}") from err
    piece = root.find("PolyData/Piece")
    if root.tag != "VTKFile" or piece is None:
        raise ValueError("not a VTK PolyData file: no PolyData/Piece element")
    points_e = piece.find("Points/DataArray")
    points = _array(points_e).reshape(-1, 3) if points_e is not None else np.zeros((0, 3))
    data = PolyData(points=points)
    for e in piece.findall("PointData/DataArray"):
        data.point_data[str(e.get("Name"))] = _array(e)
    for e in piece.findall("CellData/DataArray"):
        data.cell_data[str(e.get("Name"))] = _array(e)
    for kind in ("Verts", "Lines", "Polys"):
        conn = piece.find(f"{kind}/DataArray[@Name='connectivity']")
        offs = piece.find(f"{kind}/DataArray[@Name='offsets']")
        if conn is None or offs is None:
            continue
        c, o = _array(conn), _array(offs)
        starts = np.concatenate(([0], o[:-1])) if len(o) else o
        data.cells[kind.lower()] = [c[s:e] for s, e in zip(starts, o)]
    return data
