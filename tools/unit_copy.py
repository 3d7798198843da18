#!/usr/bin/env python3
"""Test data for unit handling (not used by the build). Usage:
    python3 tools/unit_copy.py IN.glb OUT.glb F [--giant]
Writes a 'centimetre' copy of a GLB: every length inside multiplied by F (positions,
node translations, inverse bind matrices' translations, translation animation), and a new
root node scaled 1/F, so the character is the same in metres. With --giant, only the root
scale F is added (a model F times larger)."""
import json, struct, sys
src, dst, F = sys.argv[1], sys.argv[2], float(sys.argv[3])
giant = '--giant' in sys.argv
import os
if os.path.exists(dst):
    sys.exit(f'{dst} exists: choose a new path (nothing is overwritten)')
data = open(src, 'rb').read()
magic, ver, length = struct.unpack_from('<III', data, 0)
off = 12; js = None; bin_ = b''
while off < length:
    clen, ctype = struct.unpack_from('<II', data, off); chunk = data[off+8:off+8+clen]
    if ctype == 0x4E4F534A: js = json.loads(chunk)
    else: bin_ = bytearray(chunk)
    off += 8 + clen
NC = {'SCALAR':1,'VEC2':2,'VEC3':3,'VEC4':4,'MAT4':16}
def acc_view(i):
    a = js['accessors'][i]; bv = js['bufferViews'][a['bufferView']]
    assert a['componentType'] == 5126, 'float accessors only'
    n = NC[a['type']]; start = bv.get('byteOffset',0) + a.get('byteOffset',0)
    stride = bv.get('byteStride', 4*n)
    return a, start, stride, n
def scale_acc(i, fn):
    a, start, stride, n = acc_view(i)
    for k in range(a['count']):
        o = start + k*stride
        v = fn(list(struct.unpack_from('<%df' % n, bin_, o)))
        struct.pack_into('<%df' % n, bin_, o, *v)
    if n == 3:
        for key in ('min', 'max'):
            if key in a:
                a[key] = fn(list(a[key]))
done = set()
if not giant:
    for m in js.get('meshes', []):
        for p in m['primitives']:
            for key in ['POSITION']:
                i = p['attributes'].get(key)
                if i is not None and i not in done: scale_acc(i, lambda v: [x * F for x in v]); done.add(i)
            for t in p.get('targets', []):
                i = t.get('POSITION')
                if i is not None and i not in done: scale_acc(i, lambda v: [x * F for x in v]); done.add(i)
    for n in js.get('nodes', []):
        if 'translation' in n: n['translation'] = [x*F for x in n['translation']]
        if 'matrix' in n:
            m = n['matrix']; m[12]*=F; m[13]*=F; m[14]*=F
    for s in js.get('skins', []):
        i = s.get('inverseBindMatrices')
        if i is not None and i not in done:
            def ibm(v):
                v = list(v); v[12] *= F; v[13] *= F; v[14] *= F; return v
            scale_acc(i, ibm); done.add(i)
    for an in js.get('animations', []):
        for ch in an['channels']:
            if ch['target'].get('path') == 'translation':
                i = an['samplers'][ch['sampler']]['output']
                if i not in done: scale_acc(i, lambda v: [x * F for x in v]); done.add(i)
root_scale = F if giant else 1.0/F
scene = js['scenes'][js.get('scene',0)]
js['nodes'].append({'name': 'UnitRoot', 'scale': [root_scale]*3, 'children': list(scene['nodes'])})
scene['nodes'] = [len(js['nodes'])-1]
jb = json.dumps(js).encode(); jb += b' ' * ((4 - len(jb) % 4) % 4)
bb = bytes(bin_); bb += b'\0' * ((4 - len(bb) % 4) % 4)
out = struct.pack('<III', 0x46546C67, 2, 12 + 8 + len(jb) + 8 + len(bb))
out += struct.pack('<II', len(jb), 0x4E4F534A) + jb + struct.pack('<II', len(bb), 0x004E4942) + bb
open(dst, 'wb').write(out)
