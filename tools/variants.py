#!/usr/bin/env python3
"""Test data for generality (not used by the build). Usage:
    python3 tools/variants.py IN.glb OUT_DIR [VARIANT ...]
Writes variants of a GLB that a character from elsewhere may bring, one file per variant,
OUT_DIR/<stem>_<variant>.glb (an existing file is never overwritten):
  ikctrl   two unweighted control joints added to every skin (an IK target and a pole),
           placed and animated metres away from the body, as rigs exported with IK keep them
  clips40  the clips repeated, each copy sped up or slowed down, until there are 40 or more
  late     every clip's keys start 2.5 s late (times not starting at 0)
  quant    joints as bytes, weights as normalised bytes (KHR-style quantised skinning data)
  mirror   a root node scaled -1 in x (a mirrored character)
  turned   a root node turned 90 degrees about y (the character faces +x)
  renamed  every node, mesh and clip renamed to meaningless names
  vanish   in every clip, one limb's top joint scaled to nothing for the middle third (as
           game rigs hide a weapon or a limb)
  infl8    eight influences per vertex (JOINTS_1/WEIGHTS_1): each vertex's strongest joint
           moved to the second set, the first set padded with zero weights
  morph    a morph target that widens the first skinned primitive by 15 % about its vertical
           axis, on by default (mesh weights 1), and a weights channel in the first clip (as
           body-shape sliders and faces come)
  split    every skinned mesh split in two meshes on two nodes sharing the skin (as exports
           that keep body, head and clothes apart)
  twoskins as split, the second mesh with a skin of its own (a copy: the same joints and
           inverse binds), as clothing exported on its own skin comes
  offset   a root node moving the character 3 sizes along x and -2 along z (modelled where it
           stood in a scene)
  zup      a root node turned -90 degrees about x (a Z-up export left lying on its back)
  cubic    every LINEAR sampler turned CUBICSPLINE with Catmull-Rom tangents (the same
           motion through the keys, curved between them)
  nonormals  no NORMAL attribute anywhere (normals left to the importer)
  texxform the base colour texture read through KHR_texture_transform (scale, rotation,
           offset) from TEXCOORD_1, whose coordinates undo it; TEXCOORD_0 all zero
  alphamask  every material alpha-tested (MASK, double-sided) with its texture replaced by a
           64x64 one of coloured checks pierced by round holes (as lace, hair cards and
           foliage come)
  hidden   as vanish, the limb scaled to nothing for the whole of every clip
  facerig  twelve face joints under the head, each taking the head's vertices in one sector
  twotex   as split, the second half on a material and a texture of its own (stripes)
  knight   a sword (a grey box as long as a third of the height) in one hand and a shield
           (a flat red box) on the other forearm: meshes without a skin, children of the
           hand and forearm joints, as game characters carry props
  dense    every skinned triangle cut into 16 (midpoints twice; attributes and morph
           targets interpolated, a midpoint's joints the two ends' strongest four): a
           character of ten to a hundred thousand triangles, as film-quality exports come
  gltf     a .gltf with its buffer and images as separate files, in a folder and under a
           name with spaces (URIs percent-encoded)
With no VARIANT, all of them."""
import json, math, os, random, struct, sys

ALL = ['ikctrl', 'clips40', 'late', 'quant', 'mirror', 'turned', 'renamed', 'vanish', 'infl8',
       'morph', 'split', 'twoskins', 'offset', 'zup', 'cubic', 'nonormals', 'texxform', 'alphamask', 'twotex', 'hidden', 'facerig', 'knight', 'dense', 'gltf']
NC = {'SCALAR': 1, 'VEC2': 2, 'VEC3': 3, 'VEC4': 4, 'MAT4': 16}
CT = {5120: 'b', 5121: 'B', 5122: 'h', 5123: 'H', 5125: 'I', 5126: 'f'}


def load(path):
    data = open(path, 'rb').read()
    magic, ver, length = struct.unpack_from('<III', data, 0)
    assert magic == 0x46546C67, 'not a GLB'
    off, js, bin_ = 12, None, b''
    while off < length:
        clen, ctype = struct.unpack_from('<II', data, off)
        chunk = data[off + 8:off + 8 + clen]
        if ctype == 0x4E4F534A:
            js = json.loads(chunk)
        else:
            bin_ = bytearray(chunk)
        off += 8 + clen
    return js, bytearray(bin_)


def save(js, bin_, dst):
    if os.path.exists(dst):
        sys.exit(f'{dst} exists: choose a new path (nothing is overwritten)')
    js['buffers'] = [{'byteLength': len(bin_)}]
    jb = json.dumps(js).encode()
    jb += b' ' * ((4 - len(jb) % 4) % 4)
    bb = bytes(bin_) + b'\0' * ((4 - len(bin_) % 4) % 4)
    out = struct.pack('<III', 0x46546C67, 2, 12 + 8 + len(jb) + 8 + len(bb))
    out += struct.pack('<II', len(jb), 0x4E4F534A) + jb + struct.pack('<II', len(bb), 0x004E4942) + bb
    open(dst, 'wb').write(out)


def read_acc(js, bin_, i):
    a = js['accessors'][i]
    bv = js['bufferViews'][a['bufferView']]
    n = NC[a['type']]
    fmt = CT[a['componentType']]
    size = struct.calcsize(fmt)
    start = bv.get('byteOffset', 0) + a.get('byteOffset', 0)
    stride = bv.get('byteStride', size * n)
    return [list(struct.unpack_from('<%d%s' % (n, fmt), bin_, start + k * stride)) for k in range(a['count'])]


def add_acc(js, bin_, rows, typ, ctype=5126, normalized=False, minmax=False):
    """Appends an accessor (and its buffer view) holding `rows`; returns its index."""
    while len(bin_) % 4:
        bin_.append(0)
    fmt = CT[ctype]
    n = NC[typ]
    start = len(bin_)
    for r in rows:
        bin_ += struct.pack('<%d%s' % (n, fmt), *r)
    js['bufferViews'].append({'buffer': 0, 'byteOffset': start, 'byteLength': len(bin_) - start})
    a = {'bufferView': len(js['bufferViews']) - 1, 'componentType': ctype, 'count': len(rows), 'type': typ}
    if normalized:
        a['normalized'] = True
    if minmax:
        a['min'] = [min(r[c] for r in rows) for c in range(n)]
        a['max'] = [max(r[c] for r in rows) for c in range(n)]
    js['accessors'].append(a)
    return len(js['accessors']) - 1


def wrap_root(js, **node):
    scene = js['scenes'][js.get('scene', 0)]
    node['children'] = list(scene['nodes'])
    js['nodes'].append(node)
    scene['nodes'] = [len(js['nodes']) - 1]


def bounds(js, bin_):
    lo, hi = [1e30] * 3, [-1e30] * 3
    for m in js.get('meshes', []):
        for p in m['primitives']:
            a = js['accessors'][p['attributes']['POSITION']]
            if 'min' in a:
                lo = [min(x, y) for x, y in zip(lo, a['min'])]
                hi = [max(x, y) for x, y in zip(hi, a['max'])]
    return lo, hi


def ikctrl(js, bin_):
    lo, hi = bounds(js, bin_)
    size = max(h - l for h, l in zip(hi, lo))
    new = []
    for name, t in [('IK_Target_Foot', [3.0 * size, 0.0, 0.0]), ('Pole_Knee', [0.0, 0.5 * size, 4.0 * size])]:
        js['nodes'].append({'name': name, 'translation': t})
        new.append((len(js['nodes']) - 1, t))
    scene = js['scenes'][js.get('scene', 0)]
    scene['nodes'] += [i for i, _ in new]
    for s in js.get('skins', []):
        joints = s['joints']
        ibm = read_acc(js, bin_, s['inverseBindMatrices']) if 'inverseBindMatrices' in s else \
            [[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1] for _ in joints]
        for i, t in new:
            joints.append(i)
            ibm.append([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -t[0], -t[1], -t[2], 1])
        s['inverseBindMatrices'] = add_acc(js, bin_, ibm, 'MAT4')
    # Every clip drags the IK target further away and swings the pole.
    for an in js.get('animations', []):
        t0 = min(js['accessors'][sm['input']].get('min', [0])[0] for sm in an['samplers'])
        t1 = max(js['accessors'][sm['input']].get('max', [1])[0] for sm in an['samplers'])
        times = add_acc(js, bin_, [[t0], [0.5 * (t0 + t1)], [t1]], 'SCALAR', minmax=True)
        for (i, t), far in zip(new, [8.0, -6.0]):
            vals = add_acc(js, bin_, [t, [t[0] * far, t[1] + size, t[2] * far], t], 'VEC3')
            an['samplers'].append({'input': times, 'output': vals, 'interpolation': 'LINEAR'})
            an['channels'].append({'sampler': len(an['samplers']) - 1, 'target': {'node': i, 'path': 'translation'}})


def clips40(js, bin_):
    rng = random.Random(7)
    base = list(js.get('animations', []))
    k = 0
    while len(js['animations']) < 40 and base:
        src = base[k % len(base)]
        k += 1
        f = rng.choice([0.5, 0.7, 1.3, 1.6, 2.0])
        an = json.loads(json.dumps(src))
        an['name'] = f"{src.get('name', 'clip')}_x{f}_{k}"
        remap = {}
        for sm in an['samplers']:
            if sm['input'] not in remap:
                rows = read_acc(js, bin_, sm['input'])
                remap[sm['input']] = add_acc(js, bin_, [[r[0] * f] for r in rows], 'SCALAR', minmax=True)
            sm['input'] = remap[sm['input']]
        js['animations'].append(an)


def late(js, bin_):
    for an in js.get('animations', []):
        remap = {}
        for sm in an['samplers']:
            if sm['input'] not in remap:
                rows = read_acc(js, bin_, sm['input'])
                remap[sm['input']] = add_acc(js, bin_, [[r[0] + 2.5] for r in rows], 'SCALAR', minmax=True)
            sm['input'] = remap[sm['input']]


def quant(js, bin_):
    done = {}
    for m in js.get('meshes', []):
        for p in m['primitives']:
            at = p['attributes']
            if 'JOINTS_0' in at and at['JOINTS_0'] not in done:
                rows = read_acc(js, bin_, at['JOINTS_0'])
                if max(max(r) for r in rows) < 256:
                    done[at['JOINTS_0']] = add_acc(js, bin_, rows, 'VEC4', 5121)
            if 'JOINTS_0' in at and at['JOINTS_0'] in done:
                at['JOINTS_0'] = done[at['JOINTS_0']]
            if 'WEIGHTS_0' in at and at['WEIGHTS_0'] not in done:
                rows = read_acc(js, bin_, at['WEIGHTS_0'])
                if js['accessors'][at['WEIGHTS_0']]['componentType'] == 5126:
                    q = []
                    for r in rows:
                        s = sum(r) or 1.0
                        b = [int(round(255 * x / s)) for x in r]
                        b[b.index(max(b))] += 255 - sum(b)
                        q.append(b)
                    done[at['WEIGHTS_0']] = add_acc(js, bin_, q, 'VEC4', 5121, normalized=True)
            if 'WEIGHTS_0' in at and at['WEIGHTS_0'] in done:
                at['WEIGHTS_0'] = done[at['WEIGHTS_0']]


def mirror(js, bin_):
    wrap_root(js, name='Mirror', scale=[-1.0, 1.0, 1.0])


def turned(js, bin_):
    s = math.sin(math.pi / 4)
    wrap_root(js, name='Turn', rotation=[0.0, s, 0.0, s])


def renamed(js, bin_):
    for key, stem in [('nodes', 'n'), ('meshes', 'm'), ('animations', 'a'), ('skins', 's'), ('materials', 'mat')]:
        for i, x in enumerate(js.get(key, [])):
            x['name'] = f'{stem}{i:03d}'


def vanish(js, bin_):
    # The first joint of the first skin with a parent among the joints and a subtree below it:
    # a limb's top, with luck; else any joint with children.
    joints = js['skins'][0]['joints']
    kids = {i: js['nodes'][i].get('children', []) for i in joints}
    pick = next((j for j in joints if any(k in joints for k in kids[j]) and
                 any(j in js['nodes'][p].get('children', []) for p in joints) and
                 ('arm' in js['nodes'][j].get('name', '').lower())), None)
    if pick is None:
        pick = next(j for j in joints if any(k in joints for k in kids[j]))
    for an in js.get('animations', []):
        t0 = min(js['accessors'][sm['input']].get('min', [0])[0] for sm in an['samplers'])
        t1 = max(js['accessors'][sm['input']].get('max', [1])[0] for sm in an['samplers'])
        d = t1 - t0
        ts = [t0, t0 + d / 3 - 1e-3, t0 + d / 3, t0 + 2 * d / 3, t0 + 2 * d / 3 + 1e-3, t1]
        one = js['nodes'][pick].get('scale', [1.0, 1.0, 1.0])
        vals = [one, one, [0.0] * 3, [0.0] * 3, one, one]
        an['channels'] = [c for c in an['channels'] if not (c['target'].get('node') == pick and c['target'].get('path') == 'scale')]
        an['samplers'].append({'input': add_acc(js, bin_, [[t] for t in ts], 'SCALAR', minmax=True),
                               'output': add_acc(js, bin_, vals, 'VEC3'), 'interpolation': 'LINEAR'})
        an['channels'].append({'sampler': len(an['samplers']) - 1, 'target': {'node': pick, 'path': 'scale'}})
    print('vanishing', js['nodes'][pick].get('name'), file=sys.stderr)


def inv3(m):
    a, b, c, d, e, f, g, h, i = m
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return [(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det,
            (f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det,
            (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det]


def joint_bind_pos(m):
    """A joint's position at bind from its inverse bind matrix (column-major 4x4)."""
    r = [m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10]]  # rows of the 3x3
    t = [m[12], m[13], m[14]]
    ri = inv3(r)
    return [-(ri[3 * i] * t[0] + ri[3 * i + 1] * t[1] + ri[3 * i + 2] * t[2]) for i in range(3)]


def facerig(js, bin_):
    """Twelve face joints under the head (as game rigs bring for expressions), each taking
    the head's vertices in one sector around it; they follow the head, so the character moves
    as before."""
    skin = js['skins'][0]
    joints = skin['joints']
    ibm = read_acc(js, bin_, skin['inverseBindMatrices'])
    bind_pos = lambda k: joint_bind_pos(ibm[k])
    named = [k for k, j in enumerate(joints) if 'head' in js['nodes'][j].get('name', '').lower()]
    h = named[0] if named else max(range(len(joints)), key=lambda k: bind_pos(k)[1])
    hp = bind_pos(h)
    head = joints[h]
    first = len(joints)
    for s in range(12):
        js['nodes'].append({'name': f'face_{s:02d}'})
        js['nodes'][head].setdefault('children', []).append(len(js['nodes']) - 1)
        joints.append(len(js['nodes']) - 1)
        ibm.append(list(ibm[h]))
    skin['inverseBindMatrices'] = add_acc(js, bin_, ibm, 'MAT4')
    import math
    moved = 0
    for m in js['meshes']:
        for p in m['primitives']:
            at = p['attributes']
            if 'JOINTS_0' not in at or 'WEIGHTS_0' not in at:
                continue
            jn = read_acc(js, bin_, at['JOINTS_0'])
            wt = read_acc(js, bin_, at['WEIGHTS_0'])
            pos = read_acc(js, bin_, at['POSITION'])
            for v in range(len(jn)):
                best = max(range(4), key=lambda k: wt[v][k])
                if jn[v][best] != h or wt[v][best] <= 0:
                    continue
                d = [pos[v][i] - hp[i] for i in range(3)]
                sector = int((math.atan2(d[0], d[2]) + math.pi) / (2 * math.pi) * 6) % 6 + (6 if d[1] > 0 else 0)
                jn[v] = [first + sector if (x == h and wt[v][k] > 0) else x for k, x in enumerate(jn[v])]
                moved += 1
            at['JOINTS_0'] = add_acc(js, bin_, jn, 'VEC4', 5123)
    print('face joints under', js['nodes'][head].get('name'), 'took', moved, 'vertices', file=sys.stderr)


def mat_mul(a, b):
    """Column-major 4x4 product a·b."""
    return [sum(a[k * 4 + r] * b[c * 4 + k] for k in range(4)) for c in range(4) for r in range(4)]


def box_mesh(js, bin_, half, color, name):
    """A box mesh of 24 vertices (flat normals) with half extents `half`, centred on the
    origin, on a material of its own; returns the mesh index."""
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, v = [(axis + 1) % 3, (axis + 2) % 3]
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0] * 3
                p[axis] = sign * half[axis]
                p[u] = a * half[u]
                p[v] = b * half[v]
                pos.append(p)
                n = [0.0] * 3
                n[axis] = sign
                nrm.append(n)
            quad = [base, base + 1, base + 2, base, base + 2, base + 3]
            if sign < 0:
                quad = [base, base + 2, base + 1, base, base + 3, base + 2]
            idx += [[i] for i in quad]
    js.setdefault('materials', []).append({'name': name, 'pbrMetallicRoughness': {'baseColorFactor': color}})
    js['meshes'].append({'name': name, 'primitives': [{
        'attributes': {'POSITION': add_acc(js, bin_, pos, 'VEC3', minmax=True),
                       'NORMAL': add_acc(js, bin_, nrm, 'VEC3')},
        'indices': add_acc(js, bin_, idx, 'SCALAR', 5123),
        'material': len(js['materials']) - 1}]})
    return len(js['meshes']) - 1


def knight(js, bin_):
    """A sword in one hand and a shield on the other forearm: unskinned meshes, children of
    joints (placed through the joints' inverse binds, so they sit where the hand is at rest
    in the mesh's own units)."""
    skin = js['skins'][0]
    joints = skin['joints']
    ibm = read_acc(js, bin_, skin['inverseBindMatrices'])
    bind_pos = lambda k: joint_bind_pos(ibm[k])
    lo, hi = bounds(js, bin_)
    # The mesh's own up: its longest extent (Z-up meshes under a turned node exist).
    up = max(range(3), key=lambda i: hi[i] - lo[i])
    height = hi[up] - lo[up]
    cx = (lo[0] + hi[0]) / 2
    pos = [bind_pos(k) for k in range(len(joints))]
    # The outermost joint on each side (the hands in a T or A pose), and its parent joint.
    right = max(range(len(joints)), key=lambda k: pos[k][0] - cx)
    left = min(range(len(joints)), key=lambda k: pos[k][0] - cx)
    parent = {c: i for i, nd in enumerate(js['nodes']) for c in nd.get('children', [])}
    def up_one(k):
        p = parent.get(joints[k])
        return joints.index(p) if p in joints else k
    def along_up(long, across, thick):
        h = [thick * height] * 3
        h[0] = across * height
        h[up] = long * height
        return h
    sword = box_mesh(js, bin_, along_up(0.17, 0.02, 0.008), [0.75, 0.76, 0.8, 1.0], 'Sword')
    shield = box_mesh(js, bin_, along_up(0.13, 0.012, 0.1), [0.7, 0.12, 0.1, 1.0], 'Shield')
    down = [0.0] * 3
    down[up] = -0.17 * height
    for k, mesh, off in ((right, sword, down),
                         (up_one(left), shield, [-0.04 * height, 0.0, 0.0])):
        at = [pos[k][i] + off[i] for i in range(3)]
        t = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, at[0], at[1], at[2], 1]
        js['nodes'].append({'name': js['meshes'][mesh]['name'], 'mesh': mesh, 'matrix': mat_mul(ibm[k], t)})
        js['nodes'][joints[k]].setdefault('children', []).append(len(js['nodes']) - 1)
        print(js['meshes'][mesh]['name'], 'on', js['nodes'][joints[k]].get('name'), file=sys.stderr)


def hidden(js, bin_):
    """As `vanish`, the limb scaled to nothing for the whole of every clip (a weapon kept
    hidden, an accessory switched off by scale)."""
    vanish(js, bin_)
    for an in js.get('animations', []):
        ch = an['channels'][-1]
        sm = an['samplers'][ch['sampler']]
        n = js['accessors'][sm['output']]['count']
        sm['output'] = add_acc(js, bin_, [[0.0] * 3] * n, 'VEC3')


def skinned_prims(js):
    for m in js.get('meshes', []):
        for p in m['primitives']:
            if 'JOINTS_0' in p['attributes'] and 'WEIGHTS_0' in p['attributes']:
                yield m, p


def infl8(js, bin_):
    done = {}
    for _, p in skinned_prims(js):
        at = p['attributes']
        key = (at['JOINTS_0'], at['WEIGHTS_0'])
        if key not in done:
            j = read_acc(js, bin_, at['JOINTS_0'])
            w = read_acc(js, bin_, at['WEIGHTS_0'])
            wa = js['accessors'][at['WEIGHTS_0']]
            scale = {5121: 255.0, 5123: 65535.0}.get(wa['componentType'], 1.0)
            w = [[x / scale for x in r] for r in w]
            j0, w0, j1, w1 = [], [], [], []
            for jr, wr in zip(j, w):
                k = max(range(4), key=lambda i: wr[i])
                pad = jr[k]
                j0.append([jr[i] if i != k else pad for i in range(4)])
                w0.append([wr[i] if i != k else 0.0 for i in range(4)])
                j1.append([jr[k], pad, pad, pad])
                w1.append([wr[k], 0.0, 0.0, 0.0])
            done[key] = (add_acc(js, bin_, j0, 'VEC4', 5123), add_acc(js, bin_, w0, 'VEC4'),
                         add_acc(js, bin_, j1, 'VEC4', 5123), add_acc(js, bin_, w1, 'VEC4'))
        at['JOINTS_0'], at['WEIGHTS_0'], at['JOINTS_1'], at['WEIGHTS_1'] = done[key]


def morph(js, bin_):
    m, p = next(skinned_prims(js), (None, None))
    if p is None:
        m = js['meshes'][0]
        p = m['primitives'][0]
    at = p['attributes']
    n = js['accessors'][at['POSITION']]['count']
    # Away from the vertical axis through the primitive's middle, 15 % (a body-weight
    # slider): every vertex at one place moves alike, so the surface stays closed.
    pos = read_acc(js, bin_, at['POSITION'])
    cx = sum(r[0] for r in pos) / n
    cz = sum(r[2] for r in pos) / n
    d = [[0.15 * (r[0] - cx), 0.0, 0.15 * (r[2] - cz)] for r in pos]
    p['targets'] = [{'POSITION': add_acc(js, bin_, d, 'VEC3', minmax=True)}]
    for q in m['primitives']:
        if q is not p:
            q['targets'] = [{'POSITION': add_acc(js, bin_, [[0.0, 0.0, 0.0]] * js['accessors'][q['attributes']['POSITION']]['count'], 'VEC3', minmax=True)}]
    m['weights'] = [1.0]
    mi = js['meshes'].index(m)
    node = next(i for i, nd in enumerate(js['nodes']) if nd.get('mesh') == mi)
    an = js.get('animations', [None])[0]
    if an is not None:
        t0 = min(js['accessors'][sm['input']].get('min', [0])[0] for sm in an['samplers'])
        t1 = max(js['accessors'][sm['input']].get('max', [1])[0] for sm in an['samplers'])
        times = add_acc(js, bin_, [[t0], [t1]], 'SCALAR', minmax=True)
        vals = add_acc(js, bin_, [[1.0], [0.5]], 'SCALAR')
        an['samplers'].append({'input': times, 'output': vals, 'interpolation': 'LINEAR'})
        an['channels'].append({'sampler': len(an['samplers']) - 1, 'target': {'node': node, 'path': 'weights'}})


def split(js, bin_):
    for ni, nd in enumerate(list(js['nodes'])):
        if 'mesh' not in nd or 'skin' not in nd:
            continue
        m = js['meshes'][nd['mesh']]
        a_prims, b_prims = [], []
        for p in m['primitives']:
            if 'indices' not in p or p.get('mode', 4) != 4:
                a_prims.append(p)
                continue
            idx = read_acc(js, bin_, p['indices'])
            tris = len(idx) // 3
            half = (tris // 2) * 3
            if half == 0:
                a_prims.append(p)
                continue
            pa, pb = json.loads(json.dumps(p)), json.loads(json.dumps(p))
            pa['indices'] = add_acc(js, bin_, idx[:half], 'SCALAR', 5125)
            pb['indices'] = add_acc(js, bin_, idx[half:], 'SCALAR', 5125)
            a_prims.append(pa)
            b_prims.append(pb)
        if not b_prims:
            continue
        m['primitives'] = a_prims
        js['meshes'].append({'name': m.get('name', 'mesh') + '_B', 'primitives': b_prims})
        js['nodes'].append({'name': nd.get('name', 'node') + '_B', 'mesh': len(js['meshes']) - 1, 'skin': nd['skin']})
        js['scenes'][js.get('scene', 0)]['nodes'].append(len(js['nodes']) - 1)


def twoskins(js, bin_):
    n0 = len(js['nodes'])
    split(js, bin_)
    for nd in js['nodes'][n0:]:
        if 'skin' in nd:
            js['skins'].append(json.loads(json.dumps(js['skins'][nd['skin']])))
            nd['skin'] = len(js['skins']) - 1


def offset(js, bin_):
    lo, hi = bounds(js, bin_)
    size = max(h - l for h, l in zip(hi, lo))
    wrap_root(js, name='Placed', translation=[3.0 * size, 0.0, -2.0 * size])


def zup(js, bin_):
    s = math.sin(-math.pi / 4)
    wrap_root(js, name='ZUp', rotation=[s, 0.0, 0.0, math.cos(-math.pi / 4)])


def cubic(js, bin_):
    done = {}
    for an in js.get('animations', []):
        for sm in an['samplers']:
            if sm.get('interpolation', 'LINEAR') != 'LINEAR':
                continue
            key = (sm['input'], sm['output'])
            if key not in done:
                t = [r[0] for r in read_acc(js, bin_, sm['input'])]
                v = read_acc(js, bin_, sm['output'])
                if len(v) != len(t):  # weights: several values per key; leave linear
                    done[key] = None
                else:
                    rows = []
                    for k in range(len(t)):
                        a, b = max(k - 1, 0), min(k + 1, len(t) - 1)
                        dt = (t[b] - t[a]) or 1.0
                        tan = [(y - x) / dt for x, y in zip(v[a], v[b])]
                        rows += [tan, v[k], tan]
                    typ = js['accessors'][sm['output']]['type']
                    done[key] = add_acc(js, bin_, rows, typ)
            if done[key] is not None:
                sm['output'] = done[key]
                sm['interpolation'] = 'CUBICSPLINE'


def nonormals(js, bin_):
    for m in js.get('meshes', []):
        for p in m['primitives']:
            p['attributes'].pop('NORMAL', None)
            for t in p.get('targets', []):
                t.pop('NORMAL', None)


def texxform(js, bin_):
    sc, rot, off = [2.0, 0.5], 0.3, [0.1, -0.2]
    c, s = math.cos(rot), math.sin(rot)
    done = {}
    for m in js.get('meshes', []):
        for p in m['primitives']:
            at = p['attributes']
            if 'TEXCOORD_0' not in at:
                continue
            k = at['TEXCOORD_0']
            if k not in done:
                uv = read_acc(js, bin_, k)
                a = js['accessors'][k]
                norm = {5121: 255.0, 5123: 65535.0}.get(a['componentType'], 1.0)
                new = []
                for u, v in uv:
                    x, y = u / norm - off[0], v / norm - off[1]
                    ru, rv = c * x - s * y, s * x + c * y
                    new.append([ru / sc[0], rv / sc[1]])
                done[k] = (add_acc(js, bin_, [[0.0, 0.0]] * len(uv), 'VEC2'), add_acc(js, bin_, new, 'VEC2'))
            at['TEXCOORD_0'], at['TEXCOORD_1'] = done[k]
    for mat in js.get('materials', []):
        info = mat.get('pbrMetallicRoughness', {}).get('baseColorTexture')
        if info is not None:
            info.setdefault('extensions', {})['KHR_texture_transform'] = {
                'offset': off, 'rotation': rot, 'scale': sc, 'texCoord': 1}
    js.setdefault('extensionsUsed', []).append('KHR_texture_transform')


def png_rgba(w, h, pixel):
    import zlib
    raw = b''.join(b'\0' + b''.join(bytes(pixel(x, y)) for x in range(w)) for y in range(h))
    def chunk(t, d):
        return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    return (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 6, 0, 0, 0))
            + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))


def add_png_texture(js, bin_, w, h, pixel):
    data = png_rgba(w, h, pixel)
    while len(bin_) % 4:
        bin_.append(0)
    start = len(bin_)
    bin_ += data
    js['bufferViews'].append({'buffer': 0, 'byteOffset': start, 'byteLength': len(data)})
    js.setdefault('images', []).append({'bufferView': len(js['bufferViews']) - 1, 'mimeType': 'image/png'})
    js.setdefault('samplers', []).append({})
    js.setdefault('textures', []).append({'source': len(js['images']) - 1, 'sampler': len(js['samplers']) - 1})
    return len(js['textures']) - 1


def ensure_uvs(js, bin_, prims):
    for p in prims:
        if 'TEXCOORD_0' not in p['attributes']:
            pos = read_acc(js, bin_, p['attributes']['POSITION'])
            p['attributes']['TEXCOORD_0'] = add_acc(js, bin_, [[r[0] * 3.0, r[1] * 3.0] for r in pos], 'VEC2')


def alphamask(js, bin_):
    def pixel(x, y):
        cx, cy = x % 16 - 7.5, y % 16 - 7.5
        hole = cx * cx + cy * cy < 16
        c = (200, 60, 40) if (x // 16 + y // 16) % 2 else (230, 210, 120)
        return (*c, 0 if hole else 255)
    tex = add_png_texture(js, bin_, 64, 64, pixel)
    ensure_uvs(js, bin_, [p for m in js.get('meshes', []) for p in m['primitives']])
    for mat in js.get('materials', []):
        pbr = mat.setdefault('pbrMetallicRoughness', {})
        pbr['baseColorTexture'] = {'index': tex}
        pbr.pop('baseColorFactor', None)
        mat['alphaMode'] = 'MASK'
        mat['doubleSided'] = True


def twotex(js, bin_):
    """As `split`, the second half of each skinned mesh on a material of its own with a
    texture of its own (teal and orange stripes), as characters with a body and a clothing
    texture come."""
    m0 = len(js['meshes'])
    split(js, bin_)
    tex = add_png_texture(js, bin_, 32, 32, lambda x, y: (30, 160, 150, 255) if (x // 4) % 2 else (240, 140, 40, 255))
    js.setdefault('materials', []).append({'name': 'second', 'pbrMetallicRoughness': {'baseColorTexture': {'index': tex}}})
    mat = len(js['materials']) - 1
    prims = [p for m in js['meshes'][m0:] for p in m['primitives']]
    ensure_uvs(js, bin_, prims)
    for p in prims:
        p['material'] = mat


def gltf(js, bin_):
    pass  # written by save_gltf


def save_gltf(js, bin_, dst_dir, stem):
    from urllib.parse import quote
    folder = os.path.join(dst_dir, stem + ' gltf')
    if os.path.exists(folder):
        sys.exit(f'{folder} exists: choose a new path (nothing is overwritten)')
    os.makedirs(folder)
    name = stem + ' character'
    for i, im in enumerate(js.get('images', [])):
        if 'bufferView' in im:
            bv = js['bufferViews'][im.pop('bufferView')]
            ext = '.jpg' if im.get('mimeType') == 'image/jpeg' else '.png'
            fname = f'{name} image {i}{ext}'
            start = bv.get('byteOffset', 0)
            open(os.path.join(folder, fname), 'wb').write(bytes(bin_[start:start + bv['byteLength']]))
            im['uri'] = quote(fname)
            im.pop('mimeType', None)
    js['buffers'] = [{'byteLength': len(bin_), 'uri': quote(name + '.bin')}]
    open(os.path.join(folder, name + '.bin'), 'wb').write(bytes(bin_))
    dst = os.path.join(folder, name + '.gltf')
    open(dst, 'w').write(json.dumps(js, indent=1))
    return dst


def dense(js, bin_):
    done = {}
    for _, p in skinned_prims(js):
        if 'indices' not in p or p.get('mode', 4) != 4:
            continue
        at = p['attributes']
        key = (json.dumps(at, sort_keys=True), p['indices'], json.dumps(p.get('targets', [])))
        if key in done:
            at2, ind, tg = done[key]
            p['attributes'], p['indices'] = dict(at2), ind
            if tg is not None:
                p['targets'] = tg
            continue
        cols = {}
        for name, ai in at.items():
            a = js['accessors'][ai]
            rows = read_acc(js, bin_, ai)
            if name.startswith('WEIGHTS_'):
                scale = {5121: 255.0, 5123: 65535.0}.get(a['componentType'], 1.0)
                rows = [[x / scale for x in r] for r in rows]
            cols[name] = (rows, a)
        targets = [{k: read_acc(js, bin_, v) for k, v in t.items()} for t in p.get('targets', [])]
        tris = [r[0] for r in read_acc(js, bin_, p['indices'])]
        tris = [tris[i:i + 3] for i in range(0, len(tris) - len(tris) % 3, 3)]
        sets = sorted({n[len('JOINTS_'):] for n in cols if n.startswith('JOINTS_')})

        def mid(i, j):
            for name, (rows, a) in cols.items():
                if name.startswith('JOINTS_') or name.startswith('WEIGHTS_'):
                    continue
                r = [(x + y) / 2 for x, y in zip(rows[i], rows[j])]
                if a['componentType'] != 5126:
                    r = [int(round(x)) for x in r]
                rows.append(r)
            for t in targets:
                for rows in t.values():
                    rows.append([(x + y) / 2 for x, y in zip(rows[i], rows[j])])
            inf = {}
            for s_ in sets:
                js_, ws_ = cols['JOINTS_' + s_][0], cols['WEIGHTS_' + s_][0]
                for v in (i, j):
                    for jj, ww in zip(js_[v], ws_[v]):
                        if ww > 0:
                            inf[jj] = inf.get(jj, 0.0) + ww / 2
            best = sorted(inf.items(), key=lambda kv: -kv[1])[:4 * len(sets)]
            tot = sum(w for _, w in best) or 1.0
            best += [(0, 0.0)] * (4 * len(sets) - len(best))
            for k, s_ in enumerate(sets):
                chunk = best[4 * k:4 * k + 4]
                cols['JOINTS_' + s_][0].append([jj for jj, _ in chunk])
                cols['WEIGHTS_' + s_][0].append([w / tot for _, w in chunk])
            return len(cols['POSITION'][0]) - 1

        for _ in range(2):
            edges, out = {}, []
            for a_, b_, c_ in tris:
                m_ = []
                for i, j in ((a_, b_), (b_, c_), (c_, a_)):
                    e = (min(i, j), max(i, j))
                    if e not in edges:
                        edges[e] = mid(i, j)
                    m_.append(edges[e])
                ab, bc, ca = m_
                out += [[a_, ab, ca], [ab, b_, bc], [ca, bc, c_], [ab, bc, ca]]
            tris = out
        new = {}
        for name, (rows, a) in cols.items():
            if name.startswith('JOINTS_'):
                new[name] = add_acc(js, bin_, rows, 'VEC4', 5123)
            elif name.startswith('WEIGHTS_'):
                new[name] = add_acc(js, bin_, rows, 'VEC4')
            else:
                new[name] = add_acc(js, bin_, rows, a['type'], a['componentType'], a.get('normalized', False), minmax=(name == 'POSITION'))
        p['attributes'] = new
        p['indices'] = add_acc(js, bin_, [[i] for t in tris for i in t], 'SCALAR', 5125)
        tg = None
        if targets:
            tg = [{k: add_acc(js, bin_, rows, 'VEC3', minmax=(k == 'POSITION')) for k, rows in t.items()} for t in targets]
            p['targets'] = tg
        done[key] = (dict(new), p['indices'], tg)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    src, out = sys.argv[1], sys.argv[2]
    which = sys.argv[3:] or ALL
    os.makedirs(out, exist_ok=True)
    stem = os.path.splitext(os.path.basename(src))[0]
    for v in which:
        if v not in ALL:
            sys.exit(f'unknown variant {v}; one of {ALL}')
        js, bin_ = load(src)
        globals()[v](js, bin_)
        if v == 'gltf':
            print(save_gltf(js, bin_, out, stem))
            continue
        save(js, bin_, os.path.join(out, f'{stem}_{v}.glb'))
        print(os.path.join(out, f'{stem}_{v}.glb'))


main()
