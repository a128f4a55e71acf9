"""Samples and study reports as pandas DataFrames.

A sample (the OpenAPI document's ``Sample``) is nested; its DataFrame has one column per leaf,
named by its dotted path. SI units throughout:

=========================================  =====================================================
column                                     meaning
=========================================  =====================================================
``step``, ``time``                         step number; simulated time, s
``phi``                                    packing fraction Φ (area fraction in 2D)
``z``, ``z_no_rattlers``                   coordination number, with and without rattlers
``zeta``                                   stress ratio ζ = q/p
``mu``                                     effective friction μ = τ/σ_n where a shear is defined
``p``, ``q``                               mean and deviatoric stress, Pa
``stress.xx`` ... ``stress.xy``            Love–Weber stress tensor, Pa
``inertial_number``                        I = γ̇ d sqrt(ρ/P) where a shear rate is defined
``kinetic_energy``, ``elastic_energy``     J (J/m in 2D)
``stage``                                  the experiment's stage (scenes with an experiment)
``strain.volumetric``, ``strain.deviatoric``, ``strain.axes.x`` ...  strains of the stage
``walls.<name>.position``                  wall coordinate along its axis, m
``walls.<name>.force.x`` ...               force of the grains on the wall, N (N/m in 2D)
``walls.<name>.normal_stress``             compressive normal stress on the wall, Pa
``solver.*``                               contact dynamics: sweeps, contacts, violations
``deformable.*``                           deformable grains: ``min_jacobian``,
                                           ``interpenetration``, ``dissipated_energy`` (J)
``grains.*``                               aggregates and deformable grains: the grains' ``phi``,
                                           ``z``, ``z_no_rattlers``, ``pressure`` (Pa), aspect
                                           ratios, ``mean_area`` (m²; m³ in 3D)
``primaries.*``                            aggregates: the primaries' own ``phi``, ``z``,
                                           ``z_no_rattlers`` (the top-level ones are the grains')
``drum.*``                                 rotating drum: angles (degrees), fill, torque (N·m)
=========================================  =====================================================

Vectors of two or three numbers become ``.x``, ``.y``, ``.z`` columns; lists of named objects
(the walls) are keyed by name; other lists (a drum's velocity profile) stay as Python lists in
one column.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import pandas as pd

_AXES = ("x", "y", "z")


def flatten(obj: dict[str, Any], prefix: str = "", out: dict[str, Any] | None = None) -> dict[str, Any]:
    """One sample (or any nested JSON object) as a flat ``{dotted.path: value}`` dict."""
    out = {} if out is None else out
    for key, value in obj.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flatten(value, f"{name}.", out)
        elif isinstance(value, list) and value and all(isinstance(v, dict) and "name" in v for v in value):
            for v in value:
                rest = {k: x for k, x in v.items() if k != "name"}
                flatten(rest, f"{name}.{v['name']}.", out)
        elif isinstance(value, list) and 2 <= len(value) <= 3 and all(isinstance(v, (int, float)) for v in value):
            for axis, v in zip(_AXES, value):
                out[f"{name}.{axis}"] = v
        else:
            out[name] = value
    return out


def samples_frame(samples: Iterable[dict[str, Any]]) -> pd.DataFrame:
    """Samples as a DataFrame, one row per sample in the order given, one column per field
    (module documentation). An empty list gives an empty frame with ``step`` and ``time``."""
    rows = [flatten(s) for s in samples]
    if not rows:
        return pd.DataFrame(columns=["step", "time"])
    return pd.DataFrame.from_records(rows)


def study_frame(report: dict[str, Any]) -> pd.DataFrame:
    """A study report's runs (``report["points"]``) as a DataFrame, one row per run: ``series``,
    ``label``, ``job_id``, ``state``, ``measured``, ``reference``, ``error``,
    ``relative_error``, ``pareto``, ``cost.cpu_seconds``, ``cost.wall_seconds``, ``cost.steps``,
    ``cost.solver_iterations``, and ``failure``/``note`` for failed runs; a search's probes
    carry the probed ``value``."""
    points = report.get("points") or []
    rows = [flatten(p) for p in points if isinstance(p, dict)]
    return pd.DataFrame.from_records(rows) if rows else pd.DataFrame(columns=["job_id", "state"])
