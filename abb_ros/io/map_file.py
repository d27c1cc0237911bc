"""Stability-map data files: NPZ (arrays + parameters as JSON) or CSV."""

from __future__ import annotations

import json

import numpy as np


def save_map(smap, path) -> None:
    """Write a :class:`abb_ros.model.floquet.StabilityMap` to ``path``: CSV when it ends in
    ``.csv`` (x, y, lam_max, status; '#' header), NPZ otherwise."""
    path = str(path)
    if path.endswith('.csv'):
        X, Y = np.meshgrid(smap.x_values, smap.y_values)
        rows = np.column_stack([X.ravel(), Y.ravel(), smap.lam.ravel(), smap.status.ravel()])
        header = (f'stability map, plane={smap.plane}; fixed: {json.dumps(smap.fixed)}; '
                  f'limits: {json.dumps(smap.limits)}; status 0 balanced, 1 unstable, '
                  f'2 no balanced equilibrium (lam_max inf)\n{smap.x},{smap.y},lam_max,status')
        np.savetxt(path, rows, delimiter=',', header=header, fmt='%.10g')
    else:
        np.savez_compressed(path, x_name=smap.x, y_name=smap.y, x_values=smap.x_values,
                            y_values=smap.y_values, lam_max=smap.lam, status=smap.status,
                            plane=smap.plane, fixed_json=json.dumps(smap.fixed),
                            limits_json=json.dumps(smap.limits))
