#!/usr/bin/env python3
"""Writes the binary, compressed and gzipped variants of the sfepy octahedron (and a few of the
Spot cow) that the mesh reader tests compare with the ASCII originals.

Run from this folder with meshio 5.3 and the lz4 package installed (pip install meshio lz4):
    python3 make_variants.py
The meshio-written files (octa_zlib.vtu, octa_raw.vtu, octa_bin.vtk, octa_22bin.msh,
octa_41bin.msh, octa.meshb, octa_refs.mesh) came first; this script writes the rest with small
writers of its own where meshio has no option for the variant (lz4, appended data, UInt64
headers, big-endian files, MEDIT versions 1-3, Gmsh binary of the other byte order).
"""

import base64
import gzip
import lzma
import os
import struct
import tempfile
import zlib

import lz4.block
import meshio
import numpy as np

OCTA = meshio.read("octa_refs.mesh")
POINTS = OCTA.points.astype(np.float64)
TETS = OCTA.cells_dict["tetra"].astype(np.int64)
LABELS = OCTA.cell_data_dict["medit:ref"]["tetra"].astype(np.int32)


def gz(name, data):
    # mtime 0: the same bytes on every run.
    with open(name, "wb") as f:
        with gzip.GzipFile(fileobj=f, mode="wb", mtime=0, filename="") as g:
            g.write(data)


# ---- VTU -------------------------------------------------------------------------------------

COMPRESSORS = {
    "zlib": ("vtkZLibDataCompressor", zlib.compress),
    "lz4": ("vtkLZ4DataCompressor", lambda b: lz4.block.compress(b, store_size=False)),
    "lzma": ("vtkLZMADataCompressor", lambda b: lzma.compress(b, format=lzma.FORMAT_XZ)),
}
VTK_TYPES = {"f4": "Float32", "f8": "Float64", "i4": "Int32", "i8": "Int64", "u1": "UInt8"}


def vtu_block(raw, header, compressor, order, block=32768):
    """One array's binary bytes as VTK lays them out: (header bytes, data bytes)."""
    h = order + ("I" if header == "UInt32" else "Q")
    if compressor is None:
        return struct.pack(h, len(raw)), raw
    comp = COMPRESSORS[compressor][1]
    blocks = [raw[i : i + block] for i in range(0, len(raw), block)] or [b""]
    cblocks = [comp(b) for b in blocks]
    last = len(blocks[-1])
    head = struct.pack(order + h[-1] * (3 + len(blocks)), len(blocks), block, last,
                       *[len(c) for c in cblocks])
    return head, b"".join(cblocks)


def write_vtu(name, points, tets, labels, *, fmt="binary", compressor=None, header="UInt32",
              big=False, ptype="f8", ctype="i8"):
    order = ">" if big else "<"
    n = len(tets)
    arrays = [
        ("Points", "points", points.astype(order + ptype), 3),
        ("connectivity", "cells", tets.astype(order + ctype), 1),
        ("offsets", "cells", (4 * np.arange(1, n + 1)).astype(order + ctype), 1),
        ("types", "cells", np.full(n, 10).astype(order + "u1"), 1),
        ("material", "celldata", labels.astype(order + "i4"), 1),
    ]
    attrs = f'byte_order="{"BigEndian" if big else "LittleEndian"}" header_type="{header}"'
    if compressor:
        attrs += f' compressor="{COMPRESSORS[compressor][0]}"'
    out = [f'<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" {attrs}>\n'
           f'<UnstructuredGrid>\n<Piece NumberOfPoints="{len(points)}" NumberOfCells="{n}">\n']
    appended = b""
    groups = {"points": "Points", "cells": "Cells", "celldata": "CellData"}
    current = None
    for arr_name, group, data, comps in arrays:
        if group != current:
            if current:
                out.append(f"</{groups[current]}>\n")
            out.append(f"<{groups[group]}>\n")
            current = group
        head, body = vtu_block(data.tobytes(), header, compressor, order)
        ty = VTK_TYPES[data.dtype.str[1:]]
        common = f'type="{ty}" Name="{arr_name}" NumberOfComponents="{comps}"'
        if fmt == "binary":
            # Header and data in separate base64 pieces when compressed (as VTK writes
            # them), one piece otherwise (as meshio writes them).
            if compressor:
                text = base64.b64encode(head).decode() + base64.b64encode(body).decode()
            else:
                text = base64.b64encode(head + body).decode()
            out.append(f'<DataArray {common} format="binary">\n{text}\n</DataArray>\n')
        else:
            out.append(f'<DataArray {common} format="appended" offset="{len(appended)}"/>\n')
            if fmt == "raw":
                appended += head + body
            else:
                appended += base64.b64encode(head) + base64.b64encode(body)
    out.append(f"</{groups[current]}>\n</Piece>\n</UnstructuredGrid>\n")
    data = "".join(out).encode()
    if fmt != "binary":
        enc = "raw" if fmt == "raw" else "base64"
        data += f'<AppendedData encoding="{enc}">\n_'.encode() + appended
        data += b"\n</AppendedData>\n"
    data += b"</VTKFile>\n"
    return data


def vtu(name, **kw):
    data = write_vtu(name, POINTS, TETS, LABELS, **kw)
    if name.endswith(".gz"):
        gz(name, data)
    else:
        open(name, "wb").write(data)


vtu("octa_lz4.vtu", compressor="lz4")
vtu("octa_lzma_u64.vtu", compressor="lzma", header="UInt64")
vtu("octa_zlib_u64_i32.vtu", compressor="zlib", header="UInt64", ctype="i4")
vtu("octa_be_f32.vtu", compressor="zlib", big=True, ptype="f4", ctype="i4")
vtu("octa_appended_raw_zlib.vtu", fmt="raw", compressor="zlib")
vtu("octa_appended_raw.vtu.gz", fmt="raw", header="UInt64")
vtu("octa_appended_b64.vtu.gz", fmt="base64")
vtu("octa_appended_b64_lz4.vtu", fmt="base64", compressor="lz4", header="UInt64", ctype="i4")

# ---- VTK legacy 4.2 binary (meshio) -----------------------------------------------------------

mesh = meshio.Mesh(POINTS, [("tetra", TETS)], cell_data={"material": [LABELS]})
with tempfile.TemporaryDirectory() as scratch:
    legacy = os.path.join(scratch, "octa_42bin.vtk")
    meshio.vtk.write(legacy, mesh, binary=True, fmt_version="4.2")
    gz("octa_42bin.vtk.gz", open(legacy, "rb").read())

# ---- Gmsh binary, big-endian (the writing machine's byte order) -------------------------------


def gmsh22(points, tets, labels, order):
    out = [b"$MeshFormat\n2.2 1 8\n", struct.pack(order + "i", 1), b"\n$EndMeshFormat\n"]
    out.append(f"$Nodes\n{len(points)}\n".encode())
    for k, p in enumerate(points):
        out.append(struct.pack(order + "iddd", k + 1, *p))
    out.append(f"\n$EndNodes\n$Elements\n{len(tets)}\n".encode())
    out.append(struct.pack(order + "iii", 4, len(tets), 2))
    for k, (t, l) in enumerate(zip(tets, labels)):
        out.append(struct.pack(order + "i" * 7, k + 1, int(l), int(l), *(int(v) + 1 for v in t)))
    out.append(b"\n$EndElements\n")
    return b"".join(out)


def gmsh41(points, tets, labels, order):
    q = order + "Q"
    out = [b"$MeshFormat\n4.1 1 8\n", struct.pack(order + "i", 1), b"\n$EndMeshFormat\n"]
    # Entities: volume k+1 has physical tag k+1 for each label k+1.
    tags = sorted(set(int(l) for l in labels))
    out.append(b"$Entities\n" + struct.pack(order + "QQQQ", 0, 0, 0, len(tags)))
    for t in tags:
        out.append(struct.pack(order + "i6dQiQ", t, 0, 0, 0, 0, 0, 0, 1, t, 0))
    out.append(b"\n$EndEntities\n$Nodes\n")
    n = len(points)
    out.append(struct.pack(order + "QQQQ", 1, n, 1, n) + struct.pack(order + "iiiQ", 3, tags[0], 0, n))
    out.append(struct.pack(order + "Q" * n, *range(1, n + 1)))
    out.append(points.astype(order + "f8").tobytes())
    out.append(b"\n$EndNodes\n$Elements\n")
    # One block per run of equal labels, so the tets stay in file order.
    runs = []
    for k, l in enumerate(labels):
        if runs and runs[-1][0] == l:
            runs[-1][2] += 1
        else:
            runs.append([l, k, 1])
    out.append(struct.pack(order + "QQQQ", len(runs), len(tets), 1, len(tets)))
    for l, start, m in runs:
        out.append(struct.pack(order + "iiiQ", 3, int(l), 4, m))
        for k in range(start, start + m):
            out.append(struct.pack(order + "5Q", k + 1, *(int(v) + 1 for v in tets[k])))
    out.append(b"\n$EndElements\n")
    return b"".join(out)


gz("octa_22bin_be.msh.gz", gmsh22(POINTS, TETS, LABELS, ">"))
gz("octa_41bin_be.msh.gz", gmsh41(POINTS, TETS, LABELS, ">"))

# ---- MEDIT .meshb, versions 1 to 3 (meshio writes version 4 for 64-bit ids) -------------------


def meshb(points, tets, labels, version, order):
    real = "f" if version == 1 else "d"
    pos = "i" if version <= 2 else "q"
    i = "q" if version == 4 else "i"
    isz = struct.calcsize(i)
    psz = struct.calcsize(pos)
    out = [struct.pack(order + "ii", 1, version)]
    at = 8
    at += 4 + psz + 4
    out.append(struct.pack(order + "i" + pos + "i", 3, at, 3))
    vsize = 4 + psz + isz + len(points) * (3 * struct.calcsize(real) + isz)
    at += vsize
    out.append(struct.pack(order + "i" + pos + i, 4, at, len(points)))
    for p in points:
        out.append(struct.pack(order + real * 3 + i, *p, 0))
    tsize = 4 + psz + isz + len(tets) * 5 * isz
    at += tsize
    out.append(struct.pack(order + "i" + pos + i, 8, at, len(tets)))
    for t, l in zip(tets, labels):
        out.append(struct.pack(order + i * 5, *(int(v) + 1 for v in t), int(l)))
    out.append(struct.pack(order + "i" + pos, 54, 0))
    return b"".join(out)


gz("octa_v1.meshb.gz", meshb(POINTS, TETS, LABELS, 1, "<"))
gz("octa_v2_be.meshb.gz", meshb(POINTS, TETS, LABELS, 2, ">"))
gz("octa_v3.meshb.gz", meshb(POINTS, TETS, LABELS, 3, "<"))

# ---- gzipped TetGen pair (region attribute 100) -----------------------------------------------

gz("octa_tetgen.node.gz", open("../sfepy_octahedron.node", "rb").read())
gz("octa_tetgen.ele.gz", open("../sfepy_octahedron.ele", "rb").read())
