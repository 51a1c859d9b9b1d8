#!/usr/bin/env python3
"""Builds assets/head_parts.bin from MakeHuman's CC0 meshes (../shared/data/makehuman).

The parts a face model lacks, in one file that synth/head_parts.h reads: the base mesh's neck, shoulders
and chest (the head above the jaw cut away, so that the model's own face, scalp and ears stay in front),
hair meshes and the upper part of each outfit, all at MakeHuman's base shape, in millimetres
(x to the viewer's right, y up, z to the front), with the anchor points that place them on a face model.

    tools/makehuman_parts.py [--makehuman DIR] [--out assets/head_parts.bin]

Format (little endian, counts u64 as in facesynth's model files): b"FSPARTS1", anchor count, per anchor
3 f32; part count, per part: u8 kind (0 body skin, 1 hair, 2 clothing, 3 head skin, 4 ears: the last two for face-only models), name (length + bytes), vertex count,
3·V f32 positions, 2·V f32 uv (the source mesh's, in [0, 1]; synthetic for skin), V f32 head weights
(1 = moves with the head, 0 = with the torso), triangle count, 3·T u32 indices (counter-clockwise seen
from outside). Hair and clothing are thin sheets seen from both sides: stored once, their back side (a
copy of each vertex, the winding reversed) is added when the file is read.
Anchors: right eye centre, left eye centre, right ear centre, left ear centre, nose tip, nasion
(subject's right = viewer's left = −x), and then the neck joint, about which the neck bends.
"""
import argparse
import glob
import os
import struct
import sys

import numpy as np

MM = 100.0  # MakeHuman's unit is the decimetre
LOWEST = 3.9  # dm: the chest below the shoulders; lower parts never reach a face crop
WIDEST = 2.9  # dm: the shoulders and upper arms


def read_obj(path):
    vertices, uvs, faces, groups = [], [], [], []
    group = None
    with open(path) as f:
        for line in f:
            if line.startswith('v '):
                vertices.append([float(x) for x in line.split()[1:4]])
            elif line.startswith('vt '):
                uvs.append([float(x) for x in line.split()[1:3]])
            elif line.startswith('g '):
                group = line.split()[1]
            elif line.startswith('f '):
                corners = []
                for token in line.split()[1:]:
                    fields = token.split('/')
                    corners.append((int(fields[0]) - 1, int(fields[1]) - 1 if len(fields) > 1 and fields[1] else -1))
                faces.append(corners)
                groups.append(group)
    return np.array(vertices), np.array(uvs) if uvs else np.zeros((0, 2)), faces, groups


def bound_positions(mhclo, base):
    """The proxy's vertices where its .mhclo binding puts them on the base mesh: weights of three
    base vertices plus an offset scaled by the base mesh's extent between the reference vertices (the
    .obj's own coordinates are the proxy's modelling pose, several centimetres off)."""
    scales, rows, in_verts = {}, [], False
    with open(mhclo) as f:
        for line in f:
            t = line.split()
            if not t or t[0].startswith('#'):
                continue
            if t[0].lower() in ('x_scale', 'y_scale', 'z_scale'):
                scales[t[0][0].lower()] = (int(t[1]), int(t[2]), float(t[3]))
            elif t[0] == 'verts':
                in_verts = True
            elif in_verts and len(t) == 9:
                rows.append([float(x) for x in t])
            elif in_verts and len(t) == 1 and t[0].isdigit():
                rows.append([float(t[0])] * 3 + [1, 0, 0, 0, 0, 0])
            elif t[0] == 'delete_verts':
                in_verts = False
    scale = np.array([abs(base[scales[a][0], i] - base[scales[a][1], i]) / scales[a][2] for i, a in enumerate('xyz')])
    r = np.array(rows)
    if r.ndim != 2 or len(scales) != 3:
        sys.exit(f'{mhclo}: no vertex binding or scales found')
    refs = r[:, :3].astype(int)
    return (r[:, 3:4] * base[refs[:, 0]] + r[:, 4:5] * base[refs[:, 1]] + r[:, 5:6] * base[refs[:, 2]] + r[:, 6:9] * scale)


def head_weight(y):
    """1 above the jaw, 0 at the base of the neck, smooth between (the neck bends)."""
    t = np.clip((y - 5.45) / (6.3 - 5.45), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def build_part(vertices, uvs, faces, keep_vertex, synthetic_uv=None):
    """Triangulated faces whose corners are all kept, with vertices renumbered."""
    kept_faces = [f for f in faces if all(keep_vertex[c[0]] for c in f)]
    used = sorted({c[0] for f in kept_faces for c in f})
    index = {v: i for i, v in enumerate(used)}
    uv = np.zeros((len(used), 2))
    if synthetic_uv is not None:
        uv = synthetic_uv(vertices[used])
    else:
        for f in kept_faces:
            for v, t in f:
                if t >= 0:
                    uv[index[v]] = uvs[t]
    triangles = []
    for f in kept_faces:
        ids = [index[c[0]] for c in f]
        for k in range(1, len(ids) - 1):
            triangles.append([ids[0], ids[k], ids[k + 1]])
    return vertices[used], uv, np.array(triangles, dtype=np.uint32)


def cylinder_uv(points):
    angle = np.arctan2(points[:, 0], points[:, 2])
    u = (angle / np.pi + 1) / 2
    v = np.clip((points[:, 1] - LOWEST) / (8.5 - LOWEST), 0, 1)
    return np.stack([u, v], axis=1)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--makehuman', default=os.path.join(here, '..', '..', 'shared', 'data', 'makehuman'))
    parser.add_argument('--out', default=os.path.join(here, '..', 'assets', 'head_parts.bin'))
    args = parser.parse_args()
    root = args.makehuman

    base, base_uv, faces, groups = read_obj(os.path.join(root, 'base', 'base.obj'))
    groups_of = {}
    for f, g in zip(faces, groups):
        groups_of.setdefault(g, set()).update(c[0] for c in f)

    def centre(group):
        return base[sorted(groups_of[group])].mean(axis=0)

    ears = set()
    # The ear flaps: the vertices MakeHuman's flap targets move (its other ear targets move the whole
    # side of the head around the ear).
    for target in glob.glob(os.path.join(root, 'targets', 'ears', '*-ear-flap-incr.target')):
        with open(target) as f:
            ears.update(int(line.split()[0]) for line in f if line[:1].isdigit())
    ear_points = base[sorted(ears)]
    body = sorted(groups_of['body'])
    midline = [i for i in body if abs(base[i, 0]) < 0.03 and 6.5 < base[i, 1] < 7.2]
    nose_tip = base[max(midline, key=lambda i: base[i, 2])]
    bridge = [i for i in body if abs(base[i, 0]) < 0.03 and 7.1 < base[i, 1] < 7.5 and base[i, 2] > 1.0]
    nasion = base[min(bridge, key=lambda i: base[i, 2])]
    eyeball_to_lids = np.array([0.0, 0.0, 0.10])  # the lid opening's centre lies about 10 mm before the eyeball's
    anchors = [centre('joint-r-eye') + eyeball_to_lids, centre('joint-l-eye') + eyeball_to_lids,
               ear_points[ear_points[:, 0] < 0].mean(axis=0), ear_points[ear_points[:, 0] > 0].mean(axis=0),
               nose_tip, nasion, centre('joint-neck')]

    parts = []
    # The skin below a cut from under the chin (front) up to the base of the skull (back): the face
    # model's jaw, cheeks and ears cover the top of the neck.
    on_body = np.zeros(len(base), dtype=bool)
    on_body[body] = True
    # The skin under the chin stays (it closes the face model's open underside), the chin itself goes.
    cut = 6.28 + (1.30 - base[:, 2]) * 0.35
    chin = (base[:, 2] > 1.32) & (base[:, 1] > 6.0)
    # Behind the jaw and below the ears the skin stays too: the face model ends at its jaw's back edge.
    behind_jaw = (base[:, 2] < 0.9) & (base[:, 1] < 7.0)
    not_ear = np.ones(len(base), dtype=bool)
    not_ear[sorted(ears)] = False
    keep = on_body & ((base[:, 1] < cut) | behind_jaw) & not_ear & ~chin & (base[:, 1] > LOWEST) & (np.abs(base[:, 0]) < WIDEST)
    body_faces = [f for f, g in zip(faces, groups) if g == 'body']
    # Above the neck the kept skin lies where the face model's cheeks and jaw may be: narrowed by 6 %,
    # it stays behind them where both are and still closes the gap behind the jaw.
    narrowed = base.copy()
    t = np.clip((base[:, 1] - 6.0) / 0.4, 0, 1)
    narrowed[:, 0] *= 1 - 0.06 * t * t * (3 - 2 * t)
    parts.append((0, 'body', *build_part(narrowed, base_uv, body_faces, keep, cylinder_uv)))
    # For models that are a face only (no scalp, ears or back of the head): the rest of the head, behind
    # the cheeks and temples and above the forehead, and the ears.
    # Faces are shared out whole (a face with an ear corner is the ears'), so that no strip is lost
    # between the parts.
    is_ear = ~not_ear
    head = on_body & (base[:, 1] > 6.2) & ((base[:, 2] < 1.05) | (base[:, 1] > 7.7))
    rest = [f for f in body_faces if not all(keep[c[0]] for c in f)]
    ear_faces = [f for f in rest if any(is_ear[c[0]] for c in f)]
    head_faces = [f for f in rest if not any(is_ear[c[0]] for c in f)]
    parts.append((3, 'head', *build_part(base, base_uv, head_faces, head | keep, cylinder_uv)))
    parts.append((4, 'ears', *build_part(base, base_uv, ear_faces, np.ones(len(base), dtype=bool), cylinder_uv)))

    for obj in sorted(glob.glob(os.path.join(root, 'hair', '*', '*.obj'))):
        modelled, uv, f, _ = read_obj(obj)
        v = bound_positions(obj[:-4] + '.mhclo', base)
        if len(v) != len(modelled):
            sys.exit(f'{obj}: {len(modelled)} vertices but {len(v)} bound in its .mhclo')
        # Fringes and side locks that hang before the eyes and cheeks are trimmed at the brows: on
        # another face they would cover it, and few annotated photographs show faces under hair.
        before_face = (v[:, 2] > 0.9) & (v[:, 1] < 7.5)
        parts.append((1, os.path.basename(obj)[:-4], *build_part(v, uv, f, ~before_face)))
    for obj in sorted(glob.glob(os.path.join(root, 'clothes', '*', '*.obj'))):
        modelled, uv, f, _ = read_obj(obj)
        v = bound_positions(obj[:-4] + '.mhclo', base)
        if len(v) != len(modelled):
            sys.exit(f'{obj}: {len(modelled)} vertices but {len(v)} bound in its .mhclo')
        keep = (v[:, 1] > LOWEST) & (np.abs(v[:, 0]) < WIDEST)
        parts.append((2, os.path.basename(obj)[:-4], *build_part(v, uv, f, keep)))

    out = bytearray(b'FSPARTS1')
    out += struct.pack('<Q', len(anchors))
    for a in anchors:
        out += struct.pack('<3f', *(a * MM))
    out += struct.pack('<Q', len(parts))
    for kind, name, v, uv, tri in parts:
        out += struct.pack('<BQ', kind, len(name)) + name.encode()
        out += struct.pack('<Q', len(v))
        out += (v * MM).astype('<f4').tobytes()
        out += uv.astype('<f4').tobytes()
        out += head_weight(v[:, 1]).astype('<f4').tobytes() if kind in (0, 2) else np.ones(len(v), '<f4').tobytes()
        out += struct.pack('<Q', len(tri)) + tri.astype('<u4').tobytes()
        print(f'{name}: {len(v)} vertices, {len(tri)} triangles', file=sys.stderr)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, 'wb') as f:
        f.write(out)
    print(f'{args.out}: {len(out)} bytes, anchors (mm) {np.round(np.array(anchors) * MM, 1).tolist()}', file=sys.stderr)


if __name__ == '__main__':
    main()
