"""Stability-map data files: NPZ (arrays + parameters as JSON) or CSV."""

from __future__ import annotations

import json

import numpy as np


def save_map(smap, path) -> None:
    """Write a :class:`abb_ros.model.stability.floquet.StabilityMap` to ``path``.

    CSV when it ends in ``.csv`` (x, y, lam_max, status; '#' header), NPZ otherwise.
    """
    path = str(path)
    if path.endswith('.csv'):
        X, Y = np.meshgrid(smap.x_values, smap.y_values)
        columns = [X.ravel(), Y.ravel(), smap.lam.ravel(), smap.status.ravel()]
        names = f'{smap.x},{smap.y},lam_max,status'
        if smap.lam_best is not None:
            columns += [smap.lam_best.ravel(), smap.lam_worst.ravel()]
            names += ',lam_max_best_member,lam_max_worst_member'
        rows = np.column_stack(columns)
        members = (f'; best/worst over {smap.members} sampled members of the balanced family'
                   if smap.lam_best is not None else '')
        header = (f'stability map, plane={smap.plane}; fixed: {json.dumps(smap.fixed)}; '
                  f'limits: {json.dumps(smap.limits)}; status 0 balanced, 1 unstable, '
                  f'2 no balanced equilibrium (lam_max inf){members}\n{names}')
        np.savetxt(path, rows, delimiter=',', header=header, fmt='%.10g')
    else:
        extra = {}
        if smap.lam_best is not None:
            extra = {'lam_max_best_member': smap.lam_best,
                     'lam_max_worst_member': smap.lam_worst, 'members': smap.members}
        np.savez_compressed(path, x_name=smap.x, y_name=smap.y, x_values=smap.x_values,
                            y_values=smap.y_values, lam_max=smap.lam, status=smap.status,
                            plane=smap.plane, fixed_json=json.dumps(smap.fixed),
                            limits_json=json.dumps(smap.limits), **extra)
