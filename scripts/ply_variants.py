#!/usr/bin/env python3
"""Writes one ASCII PLY mesh (plain or .gz; vertex x y z, face vertex_indices lists, as the
Stanford scans) in the forms benchmarks/load_models.cpp times:

  STEM_ascii.ply  the ASCII PLY as it is (decompressed)
  STEM_le.ply     binary_little_endian 1.0: float x y z, uchar int vertex_indices
  STEM_be.ply     binary_big_endian 1.0, the same values
  STEM_vn.obj     OBJ: `v` lines (the PLY's own number text), `vn` lines (area-weighted vertex
                  normals, %.6f), `f a//a b//b c//c` lines (polygons kept as they are)
  STEM_v.obj      OBJ: `v` and `f a b c` lines only

Coordinates in the binary files are the float32 nearest to the double of the text (Python's
array('f')), the same as a correctly rounded text-to-float reader gives in all but rare ties.
Standard library only. Usage: ply_variants.py IN.ply[.gz] OUTDIR/STEM"""
import array
import gzip
import math
import os
import struct
import sys


def read_ascii_ply(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        sys.exit(f"{path}: not a PLY file")
    body_start = data.index(b"\n", end) + 1
    header = data[:body_start].decode("ascii").splitlines()
    if "format ascii 1.0" not in header:
        sys.exit(f"{path}: only ASCII PLY is read here")
    elements, current = [], None
    for line in header:
        words = line.split()
        if words and words[0] == "element":
            current = [words[1], int(words[2]), []]
            elements.append(current)
        elif words and words[0] == "property":
            current[2].append(words[1:])
    names = [e[0] for e in elements]
    if names != ["vertex", "face"]:
        sys.exit(f"{path}: expected the elements vertex and face, found {names}")
    vertex_props = [p[-1] for p in elements[0][2]]
    if vertex_props[:3] != ["x", "y", "z"] or elements[1][2][0][0] != "list":
        sys.exit(f"{path}: expected vertex x y z … and a face list first")
    lines = data[body_start:].decode("ascii").splitlines()
    nv, nf = elements[0][1], elements[1][1]
    if len(lines) < nv + nf:
        sys.exit(f"{path}: {len(lines)} data lines, header declares {nv + nf}")
    vertex_text = [line.split()[:3] for line in lines[:nv]]
    faces = []
    for line in lines[nv:nv + nf]:
        words = line.split()
        n = int(words[0])
        faces.append([int(w) for w in words[1:1 + n]])
    return data, vertex_text, faces


def write_binary_ply(path, order, coords, faces):
    header = ("ply\nformat binary_%s_endian 1.0\ncomment converted by isin's scripts/ply_variants.py\n"
              "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
              "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
              % ("little" if order == "<" else "big", len(coords) // 3, len(faces)))
    values = array.array("f", coords)
    if (order == "<") != (sys.byteorder == "little"):
        values.byteswap()
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(values.tobytes())
        out = bytearray()
        for face in faces:
            out += struct.pack("%sB%di" % (order, len(face)), len(face), *face)
        f.write(out)


def vertex_normals(coords, faces):
    """Area-weighted vertex normals: the sum of the cross products of the faces (as fans) at
    each vertex, normalised; (0, 0, 1) where that sum is zero."""
    n = [0.0] * len(coords)
    for face in faces:
        a = face[0]
        ax, ay, az = coords[3 * a], coords[3 * a + 1], coords[3 * a + 2]
        for b, c in zip(face[1:-1], face[2:]):
            ux, uy, uz = coords[3 * b] - ax, coords[3 * b + 1] - ay, coords[3 * b + 2] - az
            vx, vy, vz = coords[3 * c] - ax, coords[3 * c + 1] - ay, coords[3 * c + 2] - az
            cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            for k in (a, b, c):
                n[3 * k] += cx
                n[3 * k + 1] += cy
                n[3 * k + 2] += cz
    out = []
    for i in range(0, len(n), 3):
        length = math.sqrt(n[i] ** 2 + n[i + 1] ** 2 + n[i + 2] ** 2)
        out.append((n[i] / length, n[i + 1] / length, n[i + 2] / length) if length > 0 else (0.0, 0.0, 1.0))
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    source, stem = sys.argv[1], sys.argv[2]
    os.makedirs(os.path.dirname(stem) or ".", exist_ok=True)
    data, vertex_text, faces = read_ascii_ply(source)
    coords = [float(w) for v in vertex_text for w in v]
    with open(stem + "_ascii.ply", "wb") as f:
        f.write(data)
    write_binary_ply(stem + "_le.ply", "<", coords, faces)
    write_binary_ply(stem + "_be.ply", ">", coords, faces)
    normals = vertex_normals(coords, faces)
    with open(stem + "_vn.obj", "w") as f:
        f.write("# %s: positions, area-weighted vertex normals, faces v//vn\n" % os.path.basename(source))
        f.writelines("v %s %s %s\n" % tuple(v) for v in vertex_text)
        f.writelines("vn %.6f %.6f %.6f\n" % nv for nv in normals)
        f.writelines("f " + " ".join("%d//%d" % (k + 1, k + 1) for k in face) + "\n" for face in faces)
    with open(stem + "_v.obj", "w") as f:
        f.write("# %s: positions and faces\n" % os.path.basename(source))
        f.writelines("v %s %s %s\n" % tuple(v) for v in vertex_text)
        f.writelines("f " + " ".join(str(k + 1) for k in face) + "\n" for face in faces)
    print("%s: %d vertices, %d faces -> %s_{ascii,le,be}.ply, %s_{vn,v}.obj"
          % (source, len(vertex_text), len(faces), stem, stem))


if __name__ == "__main__":
    main()
