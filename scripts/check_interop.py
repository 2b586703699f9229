"""Loads every geometry file under a directory with third-party readers (plyfile, trimesh,
pynrrd) and compares counts, boxes and values with `geosynth info --json`.

A manual interoperability check, not part of CI (the readers are not project
dependencies). Usage:

    pip install --user plyfile trimesh pynrrd
    geosynth demo --quick --out /tmp/demo
    python3 scripts/check_interop.py target/release/geosynth /tmp/demo

Prints one line per file and the number of mismatches; exits 1 when there are any.
"""
import json, subprocess, sys, pathlib
import numpy as np, plyfile, trimesh, nrrd

G = sys.argv[1]
root = pathlib.Path(sys.argv[2])
bad = 0
for path in sorted(root.rglob('*')):
    ext = path.suffix.lower()
    if ext not in ('.ply', '.obj', '.off', '.nrrd'):
        continue
    ours = json.loads(subprocess.run([G, 'info', '--json', str(path)], capture_output=True, text=True, check=True).stdout)
    notes = []
    try:
        if ext == '.nrrd':
            data, header = nrrd.read(str(path))
            dims = list(data.shape)
            ok = dims == list(ours['dims']) and np.isclose(np.nanmin(data), ours['min'], rtol=1e-6) and np.isclose(np.nanmax(data), ours['max'], rtol=1e-6)
            notes.append(f"pynrrd dims {dims} range {np.nanmin(data):.4g}..{np.nanmax(data):.4g}")
        else:
            if ext == '.ply':
                ply = plyfile.PlyData.read(str(path))
                v = ply['vertex']
                xyz = np.stack([v['x'], v['y'], v['z']], 1).astype(np.float64)
                nf = ply['face'].count if 'face' in ply else 0
                props = [p.name for p in v.properties]
                notes.append(f"plyfile {len(xyz)} v {nf} f props {','.join(props)}")
                ok = len(xyz) == ours['vertices'] and nf == ours['faces']
                if ours.get('bbox_min'):
                    ok &= np.allclose(xyz.min(0), ours['bbox_min'], rtol=1e-5, atol=1e-6) and np.allclose(xyz.max(0), ours['bbox_max'], rtol=1e-5, atol=1e-6)
                if nf:
                    f = np.vstack(ply['face']['vertex_indices'])
                    ok &= f.min() >= 0 and f.max() < len(xyz) and f.shape[1] == 3
            else:
                ok = True
            tm = trimesh.load(str(path), process=False)
            nv = len(tm.vertices)
            nf = len(tm.faces) if hasattr(tm, 'faces') else 0
            notes.append(f"trimesh {type(tm).__name__} {nv} v {nf} f")
            # OBJ readers may split vertices per (position, uv, normal); faces must agree.
            ok &= nf == ours['faces'] and (ext == '.obj' or nv == ours['vertices'])
            if nf:
                ok &= np.allclose(tm.bounds, [ours['bbox_min'], ours['bbox_max']], rtol=1e-5, atol=1e-6)
    except Exception as e:
        ok = False
        notes.append(f"ERROR {e!r}")
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + str(path.relative_to(root)) + ': ' + '; '.join(notes))
print(f"{bad} mismatches")
sys.exit(1 if bad else 0)
