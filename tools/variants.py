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
With no VARIANT, all of them."""
import json, math, os, random, struct, sys

ALL = ['ikctrl', 'clips40', 'late', 'quant', 'mirror', 'turned', 'renamed', 'vanish']
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
        save(js, bin_, os.path.join(out, f'{stem}_{v}.glb'))
        print(os.path.join(out, f'{stem}_{v}.glb'))


main()
