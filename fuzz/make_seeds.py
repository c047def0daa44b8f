#!/usr/bin/env python3
"""Writes the seed corpus of the fuzz targets into fuzz/corpus/<target>/ (standard library
only): small files cut from data/, hand-made edge cases of each format, and the inputs of
past bug reports. Crashes that a campaign finds are added beside these by hand (named
crash-*) and never regenerated. Run from the repository root: python3 fuzz/make_seeds.py
"""
import gzip, io, json, os, struct, zlib

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
OUT = os.path.join(ROOT, "fuzz", "corpus")


def put(target, name, data):
    d = os.path.join(OUT, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def lines(path, n):
    with open(os.path.join(ROOT, path), "rb") as f:
        return b"".join(f.readlines()[:n])


def gz(data):
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as g:
        g.write(data)
    return buf.getvalue()


tet = ([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)])

# OBJ
put("obj", "open_cube.obj", open(os.path.join(ROOT, "data/open_cube.obj"), "rb").read())
put("obj", "sphere_head.obj", lines("data/sphere.obj", 60) + b"f 1 2 3\nf -1 -2 -3\n")
put("obj", "four_one_face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n")
put("obj", "vertices_only.obj", "".join(f"v {i} {i % 3} 0.5\n" for i in range(20)))
put("obj", "polygons.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\n# c\ng x\nusemtl m\nf -4 -3 -2\n")
put("obj", "fan.obj", "v 0 0 0\n" + "".join(f"v {i} 1 0\n" for i in range(1, 40)) + "f " + " ".join(str(i) for i in range(1, 41)) + "\n")
put("obj", "nan_huge.obj", "v nan 0 0\nv 3e38 0 0\nv 0 -3e38 1\nf 1 2 3\n")

# PLY
put("ply", "torus_cloud_head.ply", lines("data/torus_cloud.ply", 40))
hdr = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
body = b"".join(struct.pack("<3f", *v) for v in tet[0]) + b"".join(struct.pack("<B3i", 3, *t) for t in tet[1])
put("ply", "tet_binary.ply", hdr.encode() + body)
put("ply", "tet_ascii.ply", hdr.replace("binary_little_endian", "ascii") + "".join("%g %g %g\n" % v for v in tet[0]) + "".join("3 %d %d %d\n" % t for t in tet[1]))
put("ply", "big_endian_normals.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n".encode() + b"".join(struct.pack(">3d3f", i, 0, 1, 0, 0, 1) for i in range(2)))

# STL
stl = b"\0" * 80 + struct.pack("<I", 4)
for t in tet[1]:
    stl += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *tet[0][i]) for i in t) + b"\0\0"
put("stl", "tet_binary.stl", stl)
put("stl", "tet_ascii.stl", "solid t\n" + "".join("facet normal 0 0 0\nouter loop\n" + "".join("vertex %g %g %g\n" % tet[0][i] for i in t) + "endloop\nendfacet\n" for t in tet[1]) + "endsolid t\n")
put("stl", "count_lies.stl", b"\0" * 80 + struct.pack("<I", 0xFFFFFFF0) + stl[84:134])

# OFF
put("off", "degenerate.off", open(os.path.join(ROOT, "data/degenerate.off"), "rb").read())
put("off", "torus_head.off", lines("data/torus.off", 30))
put("off", "tet.off", "OFF\n4 4 0\n" + "".join("%g %g %g\n" % v for v in tet[0]) + "".join("3 %d %d %d\n" % t for t in tet[1]))
put("off", "coff.off", "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n5 0 1 2 0 1\n")

# glTF / GLB
pos = b"".join(struct.pack("<3f", *v) for v in tet[0])
idx = b"".join(struct.pack("<3H", *t) for t in tet[1])
buf = pos + idx
import base64
g = {"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "translation": [1, 0, 0]}],
     "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
     "bufferViews": [{"buffer": 0, "byteLength": len(pos)}, {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
     "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
                   {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}],
     "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}]}
put("gltf", "tet_data_uri.gltf", json.dumps(g))
g2 = json.loads(json.dumps(g)); g2["buffers"] = [{"uri": "/dev/zero", "byteLength": 100}]
put("gltf", "dev_zero_buffer.gltf", json.dumps(g2))
g3 = json.loads(json.dumps(g)); g3["buffers"] = [{"uri": "missing%20file.bin", "byteLength": 72}]
put("gltf", "external_missing.gltf", json.dumps(g3))
gb = dict(g); gb["buffers"] = [{"byteLength": len(buf)}]
js = json.dumps(gb).encode(); js += b" " * (-len(js) % 4)
binc = buf + b"\0" * (-len(buf) % 4)
glb = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(binc)) + struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(binc), b"BIN\0") + binc
put("glb", "tet.glb", glb)
put("glb", "truncated.glb", glb[:60])

# XYZ
put("xyz", "cloud.xyz", "".join(f"{i} {i*i % 7} 0.5\n" for i in range(10)))
put("xyz", "normals_commas.xyz", "# c\n0,0,0,0,0,1\n1,0,0,0,0,1\n")

# NRRD (attached raw, gzip, ASCII; detached headers)
vals = [float(i % 7) - 3.0 for i in range(4 * 4 * 4)]
raw = b"".join(struct.pack("<f", v) for v in vals)
head = "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 4\nspacings: 0.5 0.5 0.5\nendian: little\n"
put("nrrd", "raw.nrrd", (head + "encoding: raw\n\n").encode() + raw)
put("nrrd", "gzip.nrrd", (head + "encoding: gzip\n\n").encode() + gz(raw))
put("nrrd", "ascii.nrrd", head + "encoding: ascii\nspace directions: (1,0,0) (0,1,0) (0,0,-1)\nspace origin: (1,2,3)\n\n" + " ".join("%g" % v for v in vals) + "\n")
put("nrrd", "dev_urandom.nhdr", "NRRD0004\ntype: float\ndimension: 3\nsizes: 8 8 8\nencoding: raw\nendian: little\ndata file: /dev/urandom\n")
put("nrrd", "huge_claim.nrrd", "NRRD0004\ntype: double\ndimension: 3\nsizes: 2000 2000 2000\nencoding: gzip\nendian: big\nbyte skip: -1\nline skip: 3\n\n")

# NPY
def npy(shape, dtype, data):
    h = "{'descr': '%s', 'fortran_order': False, 'shape': %s, }" % (dtype, str(tuple(shape)))
    h += " " * (-(10 + len(h) + 1) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(h)) + h.encode() + data
put("npy", "volume_f4.npy", npy((4, 4, 4), "<f4", raw))
put("npy", "points_f8.npy", npy((3, 3), "<f8", b"".join(struct.pack("<d", i) for i in range(9))))
put("npy", "big_endian_i2.npy", npy((2, 2, 2), ">i2", b"".join(struct.pack(">h", i) for i in range(8))))
put("npy", "claims_too_much.npy", npy((100000, 100000, 100000), "<f4", b""))

# NIfTI-1
def nifti(dims, datatype, bitpix, data):
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, *dims, 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, 352.0)
    struct.pack_into("<ff", h, 112, 1.0, 0.0)
    h[344:348] = b"n+1\0"
    return bytes(h) + b"\0" * 4 + data
nii = nifti((4, 4, 4), 16, 32, raw)
put("nifti", "f32.nii", nii)
put("nifti", "u8_scaled.nii", nifti((2, 2, 2), 2, 8, bytes(range(8))))
put("nifti_gz", "f32.nii.gz", gz(nii))
put("nifti_gz", "concatenated_members.nii.gz", gz(nii[:200]) + gz(nii[200:]))

# INRIMAGE-4
def inr(lines, data):
    h = "#INRIMAGE-4#{\n" + lines
    h += "\n" * (-(len(h) + 4) % 256) + "##}\n"
    return h.encode() + data
put("inr", "f32_4x4x4.inr", inr("XDIM=4\nYDIM=4\nZDIM=4\nVDIM=1\nTYPE=float\nPIXSIZE=32 bits\nCPU=decm\nVX=0.5\nVY=0.5\nVZ=0.75\nTX=1\nTY=2\nTZ=3\n", raw))
put("inr", "u8_sun_scaled.inr", inr("XDIM=2\nYDIM=2\nZDIM=2\nTYPE=unsigned fixed\nPIXSIZE=8 bits\nSCALE=2**0\nCPU=sun\n", bytes(range(8))))
put("inr", "i16_gz.inr", gz(inr("XDIM=2\nYDIM=2\nZDIM=2\nTYPE=signed fixed\nPIXSIZE=16 bits\nCPU=pc\n", b"".join(struct.pack("<h", i - 4) for i in range(8)))))
put("inr", "claims_too_much.inr", inr("XDIM=100000\nYDIM=100000\nZDIM=100000\nTYPE=float\nPIXSIZE=32 bits\n", b""))
put("inr", "unclosed.inr", "#INRIMAGE-4#{\nXDIM=2\nYDIM=2\n")

# Molecules
pdb = gzip.open(os.path.join(ROOT, "data/molecules/1a8o.pdb.gz")).read()
atoms = [l for l in pdb.splitlines(keepends=True) if l.startswith((b"ATOM", b"HETATM"))]
conect = [l for l in pdb.splitlines(keepends=True) if l.startswith(b"CONECT")]
put("pdb", "1a8o_head.pdb", b"".join(atoms[:40]) + b"".join(conect[:5]) + b"END\n")
put("pdb", "altloc_hybrid36.pdb", "ATOM  A0000  CA AALA A   1       1.000   2.000   3.000  0.50 20.00           C\nATOM  A0001  CA BALA A   1       1.100   2.000   3.000  0.50 20.00           C\nHETATM    3 FE   HEM A   2       0.000   0.000   0.000  1.00 20.00          FE\nCONECT    1    3\nENDMDL\n")
put("pdb", "coincident.pdb", "".join("HETATM%5d  O   HOH A%4d       0.000   0.000   0.000  1.00 20.00           O\n" % (i + 1, i + 1) for i in range(50)))
cif = gzip.open(os.path.join(ROOT, "data/molecules/1a8o.cif.gz")).read()
i = cif.find(b"_atom_site.group_PDB")
start = cif.rfind(b"loop_", 0, i)
rows = cif[start:].split(b"\n")
put("mmcif", "1a8o_atoms.cif", b"data_1A8O\n" + b"\n".join(rows[:60]) + b"\n")
put("mmcif", "quoted.cif", "data_x\nloop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\nATOM 1 C \"C A\" 1.0 2.0 3.0\nATOM 2 O 'O''' 1.5 2.0 3.0\n;\ntext\n;\n")
put("molecule_gz", "1a8o_head.pdb.gz", gz(b"".join(atoms[:40])))
put("molecule_gz", "1a8o_atoms.cif.gz", gz(b"data_1A8O\n" + b"\n".join(rows[:60]) + b"\n"))
put("molecule_gz", "bom_plain.pdb", b"\xef\xbb\xbf" + b"".join(atoms[:3]))

# Scenes
for f in sorted(os.listdir(os.path.join(ROOT, "examples/scenes"))):
    data = open(os.path.join(ROOT, "examples/scenes", f), "rb").read()
    put("scene_json" if f.endswith(".json") else "scene_toml", f, data)
node = {"sphere": {"radius": 0.5}}
for _ in range(100):
    node = {"transform": {"translate": [0.001, 0, 0], "of": node}}
put("scene_json", "transform_chain_100.json", json.dumps({"shape": node}))
put("scene_json", "brackets.json", "[" * 5000 + "]" * 5000)
put("scene_json", "unions.json", json.dumps({"shape": {"union": [{"sphere": {"center": [i * 0.1, 0, 0], "radius": 0.05}} for i in range(50)]}, "sampling": {"resolution": 1200}}))
put("scene_json", "camera.json", json.dumps({"shape": {"sphere": {}}, "camera": {"eye": [0, 0, 0], "target": [0, 0, 0], "fov": 0}}))
put("scene_toml", "dotted.toml", "[shape." + ".".join(["transform.of"] * 20) + ".sphere]\nradius = 0.5\n")
put("scene_toml", "inline.toml", "version = 1\nshape = { smooth_union = { radius = 0.1, of = [ { box = {} }, { torus = { major = 0.5 } } ] } }\n[sampling]\nband = 0.1\n")
print("seed corpus written to", OUT)
