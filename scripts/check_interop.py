"""Interoperability with third-party readers and writers, both ways:

1. converts every mesh under a directory to binary and ASCII STL with `geosynth convert`,
   then loads every geometry file there with plyfile, trimesh and pynrrd and compares
   counts, boxes and values with `geosynth info --json`, and checks that trimesh finds
   every mesh `info` calls closed (with no two vertices at one position) watertight;
2. writes PLY files with plyfile (ascii, binary little and big endian; float and double
   coordinates; three list-count/index type pairs; colours, a double and a short
   attribute; an extra element), OBJ/OFF/STL (binary and ASCII) files with trimesh and
   NRRD fields with pynrrd (raw, gzip, ascii; float, double, int64, short, uchar; attached
   and detached headers) into DIR/foreign, and checks that `geosynth info --json` reads
   the same counts, box, attributes and value range;
3. reads the demo's 16-bit height maps with Pillow and has `geosynth info --json` read a
   16-bit grey PNG Pillow wrote, comparing mode, size and channels;
4. quilts the bumpy fixture with `--heightfield-out` into a PNG and a raw map, reads them
   with Pillow and numpy and the output with plyfile, and checks that the PNG's grey
   levels give the raw heights through the report's `png_range` and that the samples,
   placed by the report's grid, lie on the output's points;
5. opens the same two maps with GDAL (through rasterio), which finds them through their
   sidecars alone (the raw map's ENVI header, the PNG's world file and aux.xml), and a
   third, GeoTIFF, map through its own tags, and checks the size, the grid against the
   report's and the heights against the raw file;
   then has GDAL write a raw Float32 terrain with its ENVI header (no size in its name)
   and checks that `geosynth info --json` reads its size and height range.
6. has GDAL write that terrain as GeoTIFF DEMs (Int16 deflated tiles, Float32 LZW with the
   floating-point predictor, big-endian Float64 BigTIFF, UInt16 PackBits tiles with
   overviews) and checks that `geosynth info --json` reads their sizes, ranges and
   placement (EPSG code, pixel size, corner), that
   `geosynth render` draws each byte for byte as it draws a raw Float32 twin, that a quilt
   of the Int16 one written as a GeoTIFF map keeps its coordinate system and grid; that
   the same DEM written by GDAL's ENVI driver in its own types (Int16 `.bil`, UInt16
   `.img`, Float64 `.dat`) reads, is placed and renders as its raw twin does, and its
   quilt's GeoTIFF map keeps the header's coordinate system and grid; that a
   DEM placed without a coordinate system (no GeoTIFF keys) is placed and so is its
   quilt's map, and that a DEM with voids on its no-data value is refused;
7. remeshes three closed meshes trimesh wrote (icosphere, torus, box) with `geosynth
   reconstruct` and checks that trimesh finds each result watertight and consistently
   wound, of the input's Euler number and within 1% of its volume;
8. has numpy write XYZ point clouds as CloudCompare, MeshLab and colour exporters do, and
   checks `info --json` on them; converts a demo quilt to .xyz and checks that numpy reads
   the positions and normals plyfile reads from its PLY;
9. has laspy write LAS point clouds (1.2 point formats 0 and 3, 1.3 format 5, 1.4 formats
   6 and 8, georeferenced at UTM coordinates) and checks that `geosynth convert` gives
   their positions, intensities, classes and colours in a PLY plyfile reads; converts a
   demo quilt to .las and checks that laspy reads plyfile's positions from it;
10. has pypcd4 write PCD clouds (ASCII, binary and LZF-compressed; colours packed as
   integers and as PCL's floats; intensity, labels) and checks that `geosynth convert`
   gives their positions, normals, colours and fields in a PLY plyfile reads; converts a
   demo quilt to binary, ASCII and compressed .pcd and checks that pypcd4 reads plyfile's
   positions, normals and patch labels from them;
11. has trimesh write a glTF scene (two meshes with vertex colours, placed by node
   transforms, one of them mirroring) and checks that `geosynth convert` merges it into
   a PLY with trimesh's placed vertices, oriented triangles and colours (converted from
   glTF's linear values to sRGB); converts a demo mesh and the demo quilt to .glb and
   .gltf and checks that trimesh reads their vertices, faces and points;
12. simplifies closed meshes trimesh wrote (a fine icosphere, a torus, and a capsule
   split along a seam, as UV-mapped meshes are) with `geosynth simplify` and checks that
   trimesh finds each result watertight and consistently wound, of the input's Euler
   number, within 2% of its volume and within the face count asked for;
13. thins a point cloud trimesh sampled on a torus (with plyfile's colours) with `geosynth
   sample --spacing` and checks in numpy that every kept point is one of the cloud's with
   its colour, no two closer than the spacing, and every point of the cloud closer than
   the spacing to a kept one.

`.ci/run` runs it on the quick demo, with pinned versions of the readers in a virtual
environment (they are not project dependencies). By hand:

    pip install --user plyfile trimesh pynrrd pillow rasterio laspy pypcd4
    geosynth demo --quick --out /tmp/demo
    python3 scripts/check_interop.py target/release/geosynth /tmp/demo

Prints one line per file and the number of mismatches; exits 1 when there are any.
Measured 2026-12-03 (plyfile 1.1.5, trimesh 5.2.0, pynrrd 1.1.3): 0 mismatches over 71 of
our files (42 of them STL) and 40 of theirs (2 STL, 3 int64 NRRD, 3 detached NRRD).
"""
import json, subprocess, sys, pathlib
import numpy as np, plyfile, trimesh, nrrd, rasterio, laspy, pypcd4
from PIL import Image

G = sys.argv[1]
root = pathlib.Path(sys.argv[2])
bad = 0
# 1. Our files, read by them; STL copies of our meshes first.
converted = root / 'stl'
converted.mkdir(exist_ok=True)
for path in sorted(p for p in root.rglob('*') if p.suffix in ('.ply', '.obj') and not {'foreign', 'stl'} & set(p.parts)):
    if json.loads(subprocess.run([G, 'info', '--json', str(path)], capture_output=True, text=True, check=True).stdout)['faces']:
        for flag, suffix in (([], ''), (['--ascii'], '_ascii')):
            out = converted / f'{path.stem}{suffix}.stl'
            subprocess.run([G, 'convert', str(path), '-o', str(out), '-q'] + flag, check=True)
for path in sorted(p for p in root.rglob('*') if 'foreign' not in p.parts):
    ext = path.suffix.lower()
    if ext not in ('.ply', '.obj', '.off', '.stl', '.nrrd'):
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
            # STL stores corners, not vertices: both sides weld them by position.
            tm = trimesh.load(str(path), process=ext == '.stl')
            nv = len(tm.vertices)
            nf = len(tm.faces) if hasattr(tm, 'faces') else 0
            notes.append(f"trimesh {type(tm).__name__} {nv} v {nf} f")
            # OBJ readers may split vertices per (position, uv, normal); faces must agree.
            ok &= nf == ours['faces'] and (ext == '.obj' or nv == ours['vertices'])
            if nf:
                ok &= np.allclose(tm.bounds, [ours['bbox_min'], ours['bbox_max']], rtol=1e-5, atol=1e-6)
            # A mesh we call closed, with no two vertices at one position, is watertight for
            # trimesh too, which welds vertices by position on loading.
            topology = ours.get('topology') or {}
            if nf and topology.get('closed_manifold') and ours.get('welded_topology') is None:
                ok &= bool(tm.is_watertight)
                notes.append(f"watertight {tm.is_watertight}")
    except Exception as e:
        ok = False
        notes.append(f"ERROR {e!r}")
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + str(path.relative_to(root)) + ': ' + '; '.join(notes))

# 2. Their files, read by us.
foreign = root / 'foreign'
foreign.mkdir(exist_ok=True)
rng = np.random.default_rng(3)
n = 500
xyz = rng.normal(size=(n, 3))
faces = rng.integers(0, n, size=(300, 3))
orders = {'ascii': '=', 'binary_little_endian': '<', 'binary_big_endian': '>'}
written = []
for encoding, order in orders.items():
    for coordinate in ['f4', 'f8']:
        for count, index in [('u1', 'i4'), ('u4', 'u4'), ('i2', 'i4')]:
            v = np.zeros(n, dtype=[('x', coordinate), ('y', coordinate), ('z', coordinate),
                                   ('nx', 'f4'), ('ny', 'f4'), ('nz', 'f4'), ('red', 'u1'),
                                   ('green', 'u1'), ('blue', 'u1'), ('quality', 'f8'),
                                   ('label', 'i2')])
            v['x'], v['y'], v['z'] = xyz.T
            v['nx'], v['ny'], v['nz'] = (xyz / np.linalg.norm(xyz, axis=1, keepdims=True)).T
            v['red'] = rng.integers(0, 256, n)
            v['quality'] = rng.random(n)
            v['label'] = rng.integers(-5, 5, n)
            f = np.empty(len(faces), dtype=[('vertex_indices', index, (3,))])
            f['vertex_indices'] = faces
            elements = [
                plyfile.PlyElement.describe(v, 'vertex'),
                plyfile.PlyElement.describe(f, 'face', len_types={'vertex_indices': count},
                                            val_types={'vertex_indices': index}),
                plyfile.PlyElement.describe(np.array([(1, 2.5)], dtype=[('a', 'i4'), ('b', 'f4')]),
                                            'camera'),
            ]
            path = foreign / f'plyfile_{encoding}_{coordinate}_{count}{index}.ply'
            plyfile.PlyData(elements, text=encoding == 'ascii', byte_order=order).write(str(path))
            written.append((path, n, len(faces), xyz, ['red', 'green', 'blue', 'quality', 'label']))
sphere = trimesh.creation.icosphere(subdivisions=2)
for name, file_type in [('obj', 'obj'), ('off', 'off'), ('stl', 'stl'), ('ascii.stl', 'stl_ascii')]:
    path = foreign / f'trimesh_icosphere.{name}'
    sphere.export(str(path), file_type=file_type)
    written.append((path, len(sphere.vertices), len(sphere.faces), np.asarray(sphere.vertices), []))
volume = rng.normal(size=(7, 5, 6))
fields = []
for encoding in ['raw', 'gzip', 'ascii']:
    for dtype in ['float32', 'float64', 'int64', 'int16', 'uint8']:
        values = (volume * 10).astype(dtype) if 'int' in dtype else volume.astype(dtype)
        path = foreign / f'pynrrd_{encoding}_{dtype}.nrrd'
        nrrd.write(str(path), values, {'encoding': encoding, 'spacings': [0.5] * 3}, index_order='F')
        fields.append((path, values))
    # A detached header (.nhdr) beside its data file.
    path = foreign / f'pynrrd_detached_{encoding}.nhdr'
    nrrd.write(str(path), volume.astype('float32'), {'encoding': encoding, 'spacings': [0.5] * 3},
               detached_header=True, index_order='F')
    fields.append((path, volume.astype('float32')))
for path, values in fields:
    result = subprocess.run([G, 'info', '--json', str(path)], capture_output=True, text=True)
    if result.returncode != 0:
        ok, note = False, result.stderr.strip()
    else:
        ours = json.loads(result.stdout)
        ok = (list(ours['dims']) == list(values.shape)
              and np.isclose(ours['min'], values.min()) and np.isclose(ours['max'], values.max())
              and np.isclose(ours['inside_share'], (values < 0).mean()))
        note = f"dims {ours['dims']} values {ours['min']:.4g}..{ours['max']:.4g}"
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + str(path.relative_to(root)) + ': ' + note)
for path, vertices, face_count, points, attributes in written:
    result = subprocess.run([G, 'info', '--json', str(path)], capture_output=True, text=True)
    if result.returncode != 0:
        ok, note = False, result.stderr.strip()
    else:
        ours = json.loads(result.stdout)
        names = [a['name'] for a in ours.get('attributes', [])]
        ok = (ours['vertices'] == vertices and ours['faces'] == face_count
              and np.allclose(ours['bbox_min'], points.min(0), atol=1e-5)
              and np.allclose(ours['bbox_max'], points.max(0), atol=1e-5)
              and all(a in names for a in attributes))
        note = f"{ours['vertices']} v {ours['faces']} f attributes {','.join(names) or '-'}"
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + str(path.relative_to(root)) + ': ' + note)
# 3. Height maps both ways: ours (the demo's `geometry/*.png`, 16-bit grey) read by Pillow,
#    and a 16-bit grey PNG written by Pillow read by us.
def check_height_map(path, expect_size=None):
    result = subprocess.run([G, 'info', '--json', str(path)], capture_output=True, text=True)
    if result.returncode != 0:
        return False, result.stderr.strip()
    ours = json.loads(result.stdout)
    with Image.open(path) as image:
        values = np.asarray(image)
        mode, size = image.mode, image.size
    ok = (mode.startswith('I;16') and ours['channels'] == 'L16'
          and [ours['width'], ours['height']] == list(size)
          and values.max() - values.min() > 6553
          and (expect_size is None or list(size) == list(expect_size)))
    return ok, f"Pillow {mode} {size[0]}x{size[1]} values {values.min()}..{values.max()}"
report = json.loads((root / 'report.json').read_text())
for entry in report.get('terrain', []):
    path = root / entry['height_map']
    ok, note = check_height_map(path, (entry['width'], entry['height']))
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + str(path.relative_to(root)) + ': ' + note)
ramp = (np.add.outer(np.arange(37) * 900, np.arange(53) * 500)).astype(np.uint16)
theirs = foreign / 'ramp_16bit.png'
Image.fromarray(ramp).save(theirs)
ok, note = check_height_map(theirs, (53, 37))
bad += not ok
print(('ok  ' if ok else 'BAD ') + str(theirs.relative_to(root)) + ': ' + note)
# 4. A point-set quilt's height map: its PNG read by Pillow and its raw twin by numpy agree
#    through the report's `png_range`, and its samples, placed by the report's grid, lie
#    on the quilt's points as plyfile reads them.
fixture = pathlib.Path(__file__).resolve().parent.parent / 'fixtures' / 'quilt_bumpy.ply'
mapped = root / 'pointmap'
mapped.mkdir(exist_ok=True)
entries = {}
for name in ['map.png', 'map.f32le', 'map.tif']:
    subprocess.run([G, 'quilt', str(fixture), '-o', str(mapped / 'out.ply'), '--scale', '1.2',
                    '--resolution', '24', '--no-quality', '-q', '--heightfield-out',
                    str(mapped / name), '--report', str(mapped / 'report.json')], check=True)
    entries[name] = json.loads((mapped / 'report.json').read_text())['heightfield_out']
png, raw = entries['map.png'], entries['map.f32le']
w, h = raw['width'], raw['height']
heights = np.fromfile(raw['path'], dtype='<f4').reshape(h, w)
with Image.open(png['path']) as image:
    mode, levels = image.mode, np.asarray(image).astype(np.float64) / 65535.0
lo, hi = png['png_range']
from_png = lo + levels * (hi - lo)
vertex = plyfile.PlyData.read(str(mapped / 'out.ply'))['vertex']
points = np.stack([vertex['x'], vertex['y'], vertex['z']], axis=1).astype(np.float64)
rows, cols = np.divmod(np.arange(w * h)[::37], w)
placed = (np.array(raw['lower_corner'])
          + raw['spacing'] * (cols[:, None] * np.array(raw['columns_axis'])
                              + (h - 1 - rows)[:, None] * np.array(raw['rows_axis']))
          + heights[rows, cols][:, None] * np.array(raw['up_axis']))
nearest = np.sqrt(((placed[:, None, :] - points[None, :, :]) ** 2).sum(-1).min(1))
ok = (mode.startswith('I;16') and levels.shape == (h, w)
      and np.abs(from_png - heights).max() <= (hi - lo) / 65535 + 1e-5
      and np.median(nearest) < 0.75 * raw['spacing'])
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"pointmap/map.png: Pillow {mode} {w}x{h}, grey to height "
      f"within {np.abs(from_png - heights).max():.2g}, samples {np.median(nearest):.3g} "
      f"from the points (median; spacing {raw['spacing']:.3g})")
# 5. GDAL reads the PNG and raw maps through their sidecars, and the GeoTIFF map through
#    its own tags: its transform puts the top-left sample's centre half a pixel in from
#    the corner, where the report's grid puts it.
spacing = raw['spacing']
top_left = np.array(raw['lower_corner'][:2]) + [0.0, spacing * (h - 1)]
for name, entry in entries.items():
    with rasterio.open(entry['path']) as dataset:
        driver, shape, transform = dataset.driver, dataset.shape, dataset.transform
        values = dataset.read(1).astype(np.float64) * dataset.scales[0] + dataset.offsets[0]
    step = [transform.a, transform.b, transform.d, transform.e]
    centre = np.array(transform * (0.5, 0.5))
    worst = np.abs(values - heights).max()
    tolerance = 0.0 if not name.endswith('.png') else (hi - lo) / 65535 + 1e-5
    ok = (shape == (h, w) and np.allclose(step, [spacing, 0, 0, -spacing], atol=1e-9)
          and np.allclose(centre, top_left, atol=1e-9) and worst <= tolerance)
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + f"pointmap/{name}: GDAL {driver} {shape[1]}x{shape[0]}, "
          f"top-left centre {centre.round(6).tolist()} (report {top_left.round(6).tolist()}), "
          f"heights within {worst:.2g}")
terrain = (100 + np.add.outer(np.arange(37) * 0.5, np.sin(np.arange(53) * 0.3))).astype('<f4')
theirs = foreign / 'terrain.f32le'
with rasterio.open(theirs, 'w', driver='ENVI', width=53, height=37, count=1, dtype='float32',
                   transform=rasterio.transform.from_origin(5e5, 4e6, 1.0, 1.0)) as dataset:
    dataset.write(terrain, 1)
result = subprocess.run([G, 'info', '--json', str(theirs)], capture_output=True, text=True)
ours = json.loads(result.stdout) if result.returncode == 0 else {}
ok = (ours.get('kind') == 'heightfield' and [ours['width'], ours['height']] == [53, 37]
      and np.isclose(ours['min'], terrain.min()) and np.isclose(ours['max'], terrain.max()))
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/terrain.f32le (GDAL ENVI): "
      + (f"{ours['width']}x{ours['height']} heights {ours['min']}..{ours['max']}" if ours
         else result.stderr.strip()))
# 6. GDAL writes the same terrain, in centimetres, as GeoTIFF DEMs the way they are shipped
#    (16-bit integers in deflated tiles, 32-bit floats with LZW and the floating-point
#    predictor, big-endian 64-bit floats in a BigTIFF, tiles with overviews): `geosynth
#    info` reads each one's size and range, and `geosynth render` draws each exactly as it
#    draws a raw Float32 twin (the same PNG bytes, so every sample is in its place).
centimetres = np.round(terrain * 100)
twin = foreign / 'terrain_cm.f32le'
with rasterio.open(twin, 'w', driver='ENVI', width=53, height=37, count=1, dtype='float32',
                   transform=rasterio.transform.from_origin(5e5, 4e6, 30.0, 30.0)) as dataset:
    dataset.write(centimetres.astype('float32'), 1)
def rendered(path):
    picture = foreign / (path.name + '.render.png')
    result = subprocess.run([G, '--quiet', 'render', str(path), '-o', str(picture)],
                            capture_output=True, text=True)
    return picture.read_bytes() if result.returncode == 0 else result.stderr.strip()
expected = rendered(twin)
placed = dict(driver='GTiff', width=53, height=37, count=1, crs='EPSG:32610',
              transform=rasterio.transform.from_origin(5e5, 4e6, 30.0, 30.0))
def info_json(path):
    result = subprocess.run([G, 'info', '--json', str(path)], capture_output=True, text=True)
    return (json.loads(result.stdout) if result.returncode == 0 else {}), result.stderr.strip()
def check_dem(path, label, file_format):
    # Its format, size, exact range, EPSG code and corner as `info` reads them, and its
    # picture byte for byte the raw twin's; returns whether all hold, and prints the line.
    ours, error = info_json(path)
    same = isinstance(expected, bytes) and rendered(path) == expected
    ok = (ours.get('format') == file_format and [ours['width'], ours['height']] == [53, 37]
          and ours['min'] == centimetres.min() and ours['max'] == centimetres.max() and same
          and ours.get('epsg') == 32610 and ours.get('pixel_size') == [30.0, 30.0]
          and ours.get('raster_origin') == [5e5, 4e6])
    print(('ok  ' if ok else 'BAD ') + f"foreign/{path.name} ({label}): "
          + (f"{ours['width']}x{ours['height']} heights {ours['min']}..{ours['max']}, "
             f"EPSG:{ours.get('epsg')} from {ours.get('raster_origin')}, "
             f"render {'the same as' if same else 'DIFFERENT from'} its raw twin's" if ours
             else error))
    return ok
def quilt_map(dem):
    # The DEM quilted into a GeoTIFF map beside it.
    stem = dem.name.replace('.', '_')
    quilted = foreign / f'{stem}_quilt.tif'
    subprocess.run([G, 'quilt', '--heightfield', str(dem), '-o',
                    str(foreign / f'{stem}_quilt.ply'), '--resolution', '20', '--no-quality',
                    '-q', '--heightfield-out', str(quilted)], check=True)
    return quilted
for name, options in [
        ('dem_int16_tiled.tif', dict(dtype='int16', tiled=True, blockxsize=16, blockysize=16,
                                     compress='deflate', predictor=2)),
        ('dem_float32_lzw.tif', dict(dtype='float32', compress='lzw', predictor=3)),
        ('dem_float64_big.tif', dict(dtype='float64', BIGTIFF='YES', ENDIANNESS='BIG')),
        ('dem_uint16_overviews.tif', dict(dtype='uint16', tiled=True, blockxsize=16,
                                          blockysize=16, compress='packbits'))]:
    path = foreign / name
    with rasterio.open(path, 'w', **placed, **options) as dataset:
        dataset.write(centimetres.astype(options['dtype']), 1)
        if 'overviews' in name:
            dataset.build_overviews([2, 4])
    bad += not check_dem(path, 'GDAL GTiff', 'TIFF')
# The same terrain as raw files with ENVI headers, as `gdal_translate -of ENVI` writes a
# DEM in its own type (Int16 and UInt16 integers, Float64) under the names GIS tools use,
# placed by the header's `map info` in UTM zone 10N.
for name, dtype in [('dem_int16.bil', 'int16'), ('dem_uint16.img', 'uint16'),
                    ('dem_float64.dat', 'float64')]:
    path = foreign / name
    with rasterio.open(path, 'w', **{**placed, 'driver': 'ENVI'}, dtype=dtype,
                       INTERLEAVE='BIL') as dataset:
        dataset.write(centimetres.astype(dtype), 1)
    bad += not check_dem(path, f'GDAL ENVI {dtype}', 'raw (ENVI header)')
# The Int16 ENVI DEM's quilt written as a GeoTIFF map is placed by the header's map info.
envi_quilt = quilt_map(foreign / 'dem_int16.bil')
with rasterio.open(foreign / 'dem_int16.bil') as theirs, rasterio.open(envi_quilt) as ours:
    ok = ours.crs == theirs.crs and ours.transform == theirs.transform
    crs, transform = ours.crs, ours.transform
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/{envi_quilt.name} (ours, read by GDAL): {crs}, "
      f"pixel {transform.a}, top-left corner ({transform.c}, {transform.f})")
# A quilt of the Int16 DEM written as a GeoTIFF map keeps the DEM's coordinate system and
# 30 m grid, from its top-left corner on.
dem = foreign / 'dem_int16_tiled.tif'
quilted = quilt_map(dem)
with rasterio.open(dem) as theirs, rasterio.open(quilted) as ours:
    crs, transform = ours.crs, ours.transform
    ok = (crs == theirs.crs and transform == theirs.transform
          and ours.shape[0] > theirs.shape[0] and ours.dtypes[0] == 'float32')
    heights = ours.read(1)
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/{quilted.name} (ours, read by GDAL): {crs}, "
      f"pixel {transform.a}, top-left corner ({transform.c}, {transform.f}), "
      f"{ours.shape[1]}x{ours.shape[0]} heights {heights.min():.0f}..{heights.max():.0f}")
# A DEM placed by a transform alone, with no coordinate system (GDAL then writes a tie
# point and a pixel scale but no GeoKeyDirectory): placed all the same, and its quilt's map
# keeps that placement and names no system either.
unnamed = foreign / 'dem_no_crs.tif'
with rasterio.open(unnamed, 'w', **{**placed, 'crs': None}, dtype='float32') as dataset:
    dataset.write(centimetres.astype('float32'), 1)
ours, _ = info_json(unnamed)
unnamed_quilt = quilt_map(unnamed)
with rasterio.open(unnamed) as theirs, rasterio.open(unnamed_quilt) as quilt_map:
    kept = quilt_map.crs is None and quilt_map.transform == theirs.transform
ok = (ours.get('raster_origin') == [5e5, 4e6] and ours.get('pixel_size') == [30.0, 30.0]
      and ours.get('geo_keys') is False and kept)
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/dem_no_crs.tif (GDAL GTiff, no CRS): placed from "
      f"{ours.get('raster_origin')}, keys {ours.get('geo_keys')}; its quilt's map "
      f"{'keeps' if kept else 'LOSES'} the transform")
voided = centimetres.astype('int16')
voided[5:8, 9:13] = -32768
path = foreign / 'dem_void.tif'
with rasterio.open(path, 'w', **placed, dtype='int16', nodata=-32768) as dataset:
    dataset.write(voided, 1)
# `info` counts and places the voids; the quilt refuses them, naming the same.
ours, _ = info_json(path)
counted = (ours.get('voids') == 12 and ours.get('no_data') == -32768
           and ours.get('first_void') == [9, 5])
result = subprocess.run([G, 'quilt', '--heightfield', str(path), '-o',
                         str(foreign / 'dem_void.ply')], capture_output=True, text=True)
refused = (result.returncode != 0 and 'samples hold the no-data value -32768, the first at '
           'column 9, row 5' in result.stderr)
ok = counted and refused
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/dem_void.tif (GDAL GTiff, no-data -32768): info "
      f"{ours.get('voids')} voids from {ours.get('first_void')}; quilt: "
      f"{result.stderr.strip() or 'read without complaint'}")
# 7. Their meshes remeshed by us: `geosynth reconstruct` of a mesh trimesh wrote gives a
#    surface trimesh finds watertight and consistently wound, of the same Euler number and
#    within 1% of the input's volume.
for name, solid in [('icosphere', trimesh.creation.icosphere(subdivisions=2)),
                    ('torus', trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)),
                    ('box', trimesh.creation.box(extents=[2.0, 1.0, 0.5]))]:
    source, remeshed = foreign / f'trimesh_{name}_solid.obj', foreign / f'{name}_remeshed.ply'
    solid.export(str(source))
    result = subprocess.run([G, 'reconstruct', str(source), '-o', str(remeshed),
                             '--resolution', '48', '-q'], capture_output=True, text=True)
    if result.returncode != 0:
        ok, note = False, result.stderr.strip()
    else:
        ours = trimesh.load(str(remeshed))
        ratio = ours.volume / solid.volume
        ok = (ours.is_watertight and ours.is_winding_consistent
              and ours.euler_number == solid.euler_number and abs(ratio - 1) < 0.01)
        note = (f"trimesh: watertight {ours.is_watertight}, Euler number {ours.euler_number} "
                f"(input {solid.euler_number}), volume {ratio:.4f} of the input's")
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + f"foreign/{remeshed.name} (ours, from trimesh's mesh): {note}")
# 8. XYZ point clouds both ways: numpy writes them as other tools do (a `//` header and
#    commas, as CloudCompare; spaces with normals, as MeshLab; integer colours), our `info`
#    reads their counts, box and normals; our `convert` writes a demo quilt as .xyz and
#    numpy reads back the positions and normals plyfile reads from its PLY.
rng = np.random.default_rng(8)
cloud = rng.normal(size=(300, 3)) * [3.0, 2.0, 1.0] + [1e3, -20.0, 5.0]
normals = rng.normal(size=(300, 3))
normals /= np.linalg.norm(normals, axis=1, keepdims=True)
rgb = rng.integers(0, 256, size=(300, 3))
for name, table, options, with_normals in [
        ('numpy_cloudcompare.xyz', np.hstack([cloud, normals]),
         dict(delimiter=',', header='X,Y,Z,Nx,Ny,Nz', comments='//'), True),
        ('numpy_meshlab.xyzn', np.hstack([cloud, normals]), dict(fmt='%.9g'), True),
        ('numpy_colours.xyzrgb', np.hstack([cloud, rgb]), dict(fmt='%.9g'), False)]:
    path = foreign / name
    np.savetxt(path, table, **options)
    ours, _ = info_json(path)
    ok = (ours.get('vertices') == 300 and ours.get('normals') == with_normals
          and np.allclose(ours.get('bbox_min'), cloud.min(0), rtol=1e-6)
          and np.allclose(ours.get('bbox_max'), cloud.max(0), rtol=1e-6)
          and (with_normals or ours.get('colors') is True))
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + f"foreign/{name} (numpy): {ours.get('format')} "
          f"{ours.get('vertices')} points, normals {ours.get('normals')}")
quilted = sorted(root.glob('geometry/quilt_*_quilted.ply'))[0]
ours_xyz = foreign / f'{quilted.stem}.xyz'
subprocess.run([G, 'convert', str(quilted), '-o', str(ours_xyz), '-q'], check=True)
table = np.loadtxt(ours_xyz, comments='#')
vertex = plyfile.PlyData.read(str(quilted))['vertex']
expected = np.stack([vertex[k] for k in ('x', 'y', 'z', 'nx', 'ny', 'nz')], axis=1)
ok = table.shape == expected.shape and np.array_equal(table.astype(np.float32), expected)
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/{ours_xyz.name} (ours, read by numpy): "
      f"{table.shape[0]} rows of {table.shape[1]}, equal to plyfile's {expected.shape}")
# 9. LAS both ways: laspy writes georeferenced clouds in five point formats, our `convert`
#    turns them into PLY (double coordinates) for plyfile to compare; our `convert` writes a
#    demo quilt as .las for laspy to read.
for version, point_format in [('1.2', 0), ('1.2', 3), ('1.3', 5), ('1.4', 6), ('1.4', 8)]:
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.array([512000.0, 5430000.0, 200.0])
    data = laspy.LasData(header)
    count = 500
    data.x = 512000 + rng.random(count) * 80
    data.y = 5430000 + rng.random(count) * 60
    data.z = 200 + rng.random(count) * 15
    data.intensity = rng.integers(0, 65536, count)
    data.classification = rng.integers(0, 32, count)
    coloured = 'red' in data.point_format.dimension_names
    if coloured:
        for channel in ('red', 'green', 'blue'):
            setattr(data, channel, rng.integers(0, 256, count) * 257)
    path = foreign / f'laspy_{version}_{point_format}.las'
    data.write(path)
    as_ply = foreign / f'{path.stem}.ply'
    subprocess.run([G, 'convert', str(path), '-o', str(as_ply), '-q'], check=True)
    vertex = plyfile.PlyData.read(str(as_ply))['vertex']
    ours = np.stack([vertex[k] for k in ('x', 'y', 'z')], axis=1)
    theirs = np.stack([np.asarray(data.x), np.asarray(data.y), np.asarray(data.z)], axis=1)
    error = np.abs(ours - theirs).max()
    # Positions are kept in single precision relative to the data's centre: within 1e-5.
    ok = (len(ours) == count and error < 1e-5
          and np.array_equal(vertex['intensity'], np.asarray(data.intensity))
          and np.array_equal(vertex['classification'], np.asarray(data.classification)))
    if coloured:
        ok &= np.array_equal(vertex['red'], np.asarray(data.red) // 257)
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + f"foreign/{path.name} (laspy): {len(ours)} points, "
          f"position error {error:.1e}, colours {coloured}")
ours_las = foreign / f'{quilted.stem}.las'
subprocess.run([G, 'convert', str(quilted), '-o', str(ours_las), '-q'], check=True)
read_back = laspy.read(ours_las)
positions = np.stack([np.asarray(read_back.x), np.asarray(read_back.y),
                      np.asarray(read_back.z)], axis=1)
quilt_vertex = plyfile.PlyData.read(str(quilted))['vertex']
expected = np.stack([quilt_vertex[k] for k in ('x', 'y', 'z')], axis=1).astype(np.float64)
error = np.abs(positions - expected).max() if positions.shape == expected.shape else np.inf
ok = read_back.header.version == laspy.header.Version(1, 2) and error < 1e-7
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/{ours_las.name} (ours, read by laspy): "
      f"{len(positions)} points, position error {error:.1e}")
# 10. PCD both ways: pypcd4 writes clouds in its three encodings (colours packed as
#     integers, and in binary as PCL's floats; intensity, label), our `convert` turns them
#     into PLY for plyfile to compare; our `convert` writes a demo quilt as binary, ASCII
#     and compressed .pcd for pypcd4 to read (positions, normals, patch labels).
side = np.arange(400) % 20
xyz = np.column_stack([side * 0.25, (np.arange(400) // 20) * 0.5, (side % 3) * 0.125])
up = np.tile([0.0, 0.0, 1.0], (400, 1))
channels = rng.integers(0, 256, size=(400, 3)).astype(np.uint32)
packed = channels[:, 0] << 16 | channels[:, 1] << 8 | channels[:, 2]
intensity = (np.arange(400) % 9) * 0.5
label = (np.arange(400) % 7).astype(np.uint16)
for colour_type, encodings in [(np.uint32, ('ascii', 'binary', 'binary_compressed')),
                               (np.float32, ('binary', 'binary_compressed'))]:
    colours = packed if colour_type is np.uint32 else packed.view(np.float32)
    columns = [*xyz.T.astype(np.float32), *up.T.astype(np.float32), colours,
               intensity.astype(np.float32), label]
    fields = ('x', 'y', 'z', 'normal_x', 'normal_y', 'normal_z', 'rgb', 'intensity', 'label')
    types = (np.float32,) * 6 + (colour_type, np.float32, np.uint16)
    cloud_pcd = pypcd4.PointCloud.from_points(columns, fields, types)
    for encoding in encodings:
        path = foreign / f'pypcd4_{np.dtype(colour_type).name}_{encoding}.pcd'
        cloud_pcd.save(path, encoding=pypcd4.Encoding(encoding))
        ours, _ = info_json(path)
        as_ply = foreign / f'{path.stem}.ply'
        subprocess.run([G, 'convert', str(path), '-o', str(as_ply), '-q'], check=True)
        vertex = plyfile.PlyData.read(str(as_ply))['vertex']
        got = lambda *keys: np.stack([vertex[k] for k in keys], axis=1)
        ok = (ours.get('encoding') == encoding and len(vertex) == 400
              and np.array_equal(got('x', 'y', 'z'), xyz)
              and np.array_equal(got('nx', 'ny', 'nz'), up)
              and np.array_equal(got('red', 'green', 'blue'), channels)
              and np.array_equal(vertex['intensity'], intensity)
              and np.array_equal(vertex['label'], label))
        bad += not ok
        print(('ok  ' if ok else 'BAD ') + f"foreign/{path.name} (pypcd4): {ours.get('format')} "
              f"{ours.get('encoding')}, {len(vertex)} points")
expected = np.stack([quilt_vertex[k] for k in ('x', 'y', 'z', 'nx', 'ny', 'nz')], axis=1)
for flags, encoding in [([], 'binary'), (['--ascii'], 'ascii'),
                        (['--compressed'], 'binary_compressed')]:
    ours_pcd = foreign / f'{quilted.stem}_{encoding}.pcd'
    subprocess.run([G, 'convert', str(quilted), '-o', str(ours_pcd), '-q'] + flags, check=True)
    read_back = pypcd4.PointCloud.from_path(ours_pcd)
    table = read_back.numpy(('x', 'y', 'z', 'normal_x', 'normal_y', 'normal_z'))
    ok = (read_back.metadata.data.value == encoding and table.shape == expected.shape
          and np.array_equal(table.astype(np.float32), expected)
          and np.array_equal(read_back.numpy(('patch',)).ravel(), quilt_vertex['patch']))
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + f"foreign/{ours_pcd.name} (ours, read by pypcd4): "
          f"{table.shape[0]} points, {read_back.metadata.data.value}")
# 11. glTF both ways: trimesh writes a scene of two coloured meshes placed by node
#     transforms (one a mirror) as .glb; our `convert` merges it into a PLY whose vertices,
#     oriented triangles and colours plyfile compares with trimesh's own placed meshes
#     (glTF colours are linear: we keep sRGB, so trimesh's bytes c come back as
#     srgb(c / 255) × 255). Our `convert` writes a demo mesh and the demo quilt as .glb
#     and .gltf for trimesh to read (vertices, faces, points).
def srgb_bytes(linear_bytes):
    l = linear_bytes / 255.0
    s = np.where(l <= 0.0031308, 12.92 * l, 1.055 * l ** (1 / 2.4) - 0.055)
    return np.round(s * 255)
def oriented_faces(faces):
    """Triangles as index triples starting at their smallest index: a set two meshes
    share when they draw the same oriented triangles."""
    return {tuple(np.roll(t, -int(np.argmin(t)))) for t in faces}
scene = trimesh.Scene()
placed = []
for name, solid, transform in [
        ('ico', trimesh.creation.icosphere(subdivisions=1),
         trimesh.transformations.translation_matrix([3.0, 0.0, 0.0])),
        ('torus', trimesh.creation.torus(major_radius=1.0, minor_radius=0.3),
         trimesh.transformations.rotation_matrix(0.7, [0, 1, 1]) @ np.diag([1.0, -2.0, 1.0, 1.0]))]:
    solid.visual.vertex_colors = np.column_stack(
        [rng.integers(0, 256, size=(len(solid.vertices), 3)), np.full(len(solid.vertices), 255)]
    ).astype(np.uint8)
    scene.add_geometry(solid, node_name=name, transform=transform)
    moved = solid.copy()
    moved.apply_transform(transform)
    placed.append(moved)
theirs_glb = foreign / 'trimesh_scene.glb'
scene.export(str(theirs_glb))
as_ply = foreign / 'trimesh_scene_glb.ply'
subprocess.run([G, 'convert', str(theirs_glb), '-o', str(as_ply), '-q'], check=True)
ours = plyfile.PlyData.read(str(as_ply))
vertices = np.stack([ours['vertex'][k] for k in ('x', 'y', 'z')], axis=1).astype(np.float64)
faces = np.stack(ours['face']['vertex_indices'])
their_vertices = np.concatenate([m.vertices for m in placed])
their_colours = np.concatenate([m.visual.vertex_colors[:, :3] for m in placed])
offsets = np.cumsum([0] + [len(m.vertices) for m in placed])
their_faces = np.concatenate([m.faces + k for m, k in zip(placed, offsets)])
# Our vertices matched to theirs by position (sorted the same way: every one differs).
order = np.lexsort(vertices.T)
their_order = np.lexsort(their_vertices.T)
theirs_of_ours = np.empty(len(order), dtype=np.int64)
theirs_of_ours[order] = their_order[:len(order)]
colours = np.stack([ours['vertex'][k] for k in ('red', 'green', 'blue')], axis=1)
ok = (vertices.shape == their_vertices.shape
      and np.allclose(vertices[order], their_vertices[their_order], atol=1e-5)
      and np.array_equal(colours[order], srgb_bytes(their_colours[their_order].astype(np.float64)))
      and oriented_faces(theirs_of_ours[faces]) == oriented_faces(their_faces))
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/{theirs_glb.name} (trimesh): {len(vertices)} vertices, "
      f"{len(faces)} triangles against trimesh's {len(their_faces)}")
mesh_ply = sorted(p for p in root.rglob('*.ply')
                  if 'foreign' not in p.parts and 'face' in plyfile.PlyData.read(str(p)))[0]
mesh_data = plyfile.PlyData.read(str(mesh_ply))
mesh_vertices = np.stack([mesh_data['vertex'][k] for k in ('x', 'y', 'z')], axis=1)
mesh_faces = np.stack(mesh_data['face']['vertex_indices'])
quilt_points = np.stack([quilt_vertex[k] for k in ('x', 'y', 'z')], axis=1)
for source, ext in [(mesh_ply, 'glb'), (mesh_ply, 'gltf'), (quilted, 'glb'), (quilted, 'gltf')]:
    ours_gltf = foreign / f'{source.stem}.{ext}'
    subprocess.run([G, 'convert', str(source), '-o', str(ours_gltf), '-q'], check=True)
    loaded = trimesh.load(str(ours_gltf), process=False)
    geometry = list(loaded.geometry.values())[0] if isinstance(loaded, trimesh.Scene) else loaded
    if source == mesh_ply:
        ok = (np.array_equal(np.asarray(geometry.vertices, dtype=np.float32), mesh_vertices)
              and np.array_equal(geometry.faces, mesh_faces))
        what = f"{len(geometry.vertices)} vertices, {len(geometry.faces)} faces"
    else:
        ok = np.array_equal(np.asarray(geometry.vertices, dtype=np.float32), quilt_points)
        what = f"{len(geometry.vertices)} points ({type(geometry).__name__})"
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + f"foreign/{ours_gltf.name} (ours, read by trimesh): {what}")
# 12. Their meshes simplified by us: `geosynth simplify` of closed meshes trimesh wrote (a
#    fine icosphere; a torus; a capsule split along a seam, its vertices doubled there as a
#    UV-mapped mesh's are) gives at most the faces asked for, and trimesh, which welds by
#    position, finds each result watertight and consistently wound, of the input's Euler
#    number and within 2% of its volume.
capsule = trimesh.creation.capsule(height=1.0, radius=0.5, count=[32, 32])
seam = np.abs(capsule.vertices[:, 0]) < 1e-9
split_vertices = list(capsule.vertices)
copy_of = {}
split_faces = capsule.faces.copy()
for i, face in enumerate(capsule.faces):
    # Faces on the +y side of the seam plane x = 0 take copies of the seam's vertices.
    if capsule.vertices[face].mean(axis=0)[1] > 0:
        for j, v in enumerate(face):
            if seam[v]:
                if v not in copy_of:
                    copy_of[v] = len(split_vertices)
                    split_vertices.append(capsule.vertices[v])
                split_faces[i, j] = copy_of[v]
seamed = trimesh.Trimesh(np.array(split_vertices), split_faces, process=False)
print(f"     the capsule's seam: {len(copy_of)} vertices doubled")
for name, solid, target in [('icosphere', trimesh.creation.icosphere(subdivisions=5), 1000),
                            ('torus', trimesh.creation.torus(major_radius=1.0, minor_radius=0.35), 600),
                            ('seamed_capsule', seamed, 400)]:
    source, fewer = foreign / f'trimesh_{name}_dense.ply', foreign / f'{name}_simplified.ply'
    solid.export(str(source))
    result = subprocess.run([G, 'simplify', str(source), '-o', str(fewer), '--faces',
                             str(target), '-q'], capture_output=True, text=True)
    if result.returncode != 0:
        ok, note = False, result.stderr.strip()
    else:
        ours = trimesh.load(str(fewer))
        reference = trimesh.Trimesh(solid.vertices, solid.faces)  # welded, as ours is read
        ratio = ours.volume / reference.volume
        ok = (len(ours.faces) <= target and ours.is_watertight and ours.is_winding_consistent
              and ours.euler_number == reference.euler_number and abs(ratio - 1) < 0.02)
        note = (f"{len(solid.faces)} → {len(ours.faces)} faces (asked {target}); trimesh: "
                f"watertight {ours.is_watertight}, Euler number {ours.euler_number} (input "
                f"{reference.euler_number}), volume {ratio:.4f} of the input's")
    bad += not ok
    print(('ok  ' if ok else 'BAD ') + f"foreign/{fewer.name} (ours, from trimesh's mesh): {note}")
# 13. Their point cloud thinned by us: trimesh samples a torus (with a random colour a
#    point, written by plyfile), `geosynth sample --spacing` keeps a Poisson disk of its
#    points, and numpy checks the disk by brute force.
torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)
cloud, _ = trimesh.sample.sample_surface(torus, 6000, seed=13)
colours = np.random.default_rng(13).integers(0, 256, size=(len(cloud), 3), dtype=np.uint8)
table = np.empty(len(cloud), dtype=[('x', 'f4'), ('y', 'f4'), ('z', 'f4'),
                                    ('red', 'u1'), ('green', 'u1'), ('blue', 'u1')])
for axis, name in enumerate('xyz'):
    table[name] = cloud[:, axis]
for channel, name in enumerate(['red', 'green', 'blue']):
    table[name] = colours[:, channel]
dense, thin = foreign / 'trimesh_torus_cloud.ply', foreign / 'torus_cloud_thinned.ply'
plyfile.PlyData([plyfile.PlyElement.describe(table, "vertex")]).write(str(dense))
spacing = 0.1
result = subprocess.run([G, 'sample', str(dense), '-o', str(thin), '--spacing', str(spacing),
                         '-q'], capture_output=True, text=True)
if result.returncode != 0:
    ok, note = False, result.stderr.strip()
else:
    kept = plyfile.PlyData.read(str(thin))["vertex"]
    given = np.stack([table[n].astype(np.float64) for n in ['x', 'y', 'z', 'red', 'green', 'blue']], 1)
    ours = np.stack([kept[n].astype(np.float64) for n in ['x', 'y', 'z', 'red', 'green', 'blue']], 1)
    rows = {tuple(row) for row in given}
    members = all(tuple(row) in rows for row in ours)
    positions, everything = ours[:, :3], given[:, :3]
    apart = np.sqrt(((positions[:, None, :] - positions[None, :, :]) ** 2).sum(-1))
    np.fill_diagonal(apart, np.inf)
    gaps = np.sqrt(((everything[:, None, :] - positions[None, :, :]) ** 2).sum(-1)).min(1)
    # Distances are compared in double precision, against the spacing as a float.
    limit = float(np.float32(spacing))
    ok = members and apart.min() >= limit * (1 - 1e-6) and gaps.max() < limit * (1 + 1e-6)
    note = (f"{len(given)} → {len(ours)} points; kept are the cloud's own with their colours: "
            f"{members}; closest pair {apart.min():.4f}, widest gap {gaps.max():.4f} "
            f"(spacing {spacing})")
bad += not ok
print(('ok  ' if ok else 'BAD ') + f"foreign/{thin.name} (ours, from trimesh's cloud): {note}")
print(f"{bad} mismatches")
sys.exit(1 if bad else 0)
