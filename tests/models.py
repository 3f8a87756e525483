"""Test models the packages do not have: closed, consistently oriented surfaces of any size,
written as binary STL with numpy (independent of the code under test)."""
import numpy as np


def periodic_grid_triangles(nu, nv):
    """Two triangles per quad of an nu x nv grid of vertices (index i * nv + j) that wraps around
    in both directions: a closed torus-like surface."""
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    return np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])


def bumpy_torus(nu, nv, major=1.0, minor=0.4, bump=0.15):
    """A torus whose tube radius varies as minor * (1 + bump * sin(5u) cos(3v)): closed, genus 1,
    no symmetry plane through a grid axis. Returns (vertices, triangles), outward oriented."""
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    U, V = np.meshgrid(u, v, indexing="ij")
    r = minor * (1 + bump * np.sin(5 * U) * np.cos(3 * V))
    x = (major + r * np.cos(V)) * np.cos(U)
    y = (major + r * np.cos(V)) * np.sin(U)
    z = r * np.sin(V)
    verts = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    return verts, periodic_grid_triangles(nu, nv)


def trefoil_tube(nu, nv, radius=0.35):
    """A tube around the trefoil knot (x, y, z) = (sin t + 2 sin 2t, cos t - 2 cos 2t, -sin 3t):
    closed, genus 1, knotted, so that cells see thin necks and near-tangent passes. The tube's
    frame is the curve's rotation-minimising frame (parallel transport), closed up by spreading
    the holonomy angle along the curve so the last ring meets the first. Returns (vertices,
    triangles), outward oriented."""
    t = 2 * np.pi * np.arange(nu) / nu
    c = np.stack([np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)], -1)
    d = np.stack([np.cos(t) + 4 * np.cos(2 * t), -np.sin(t) + 4 * np.sin(2 * t), -3 * np.cos(3 * t)], -1)
    tan = d / np.linalg.norm(d, axis=1, keepdims=True)
    n = np.cross(tan[0], [0.0, 0.0, 1.0])
    n /= np.linalg.norm(n)
    normals = [n]
    for i in range(1, nu + 1):  # parallel transport, one step past the end to measure holonomy
        ti = tan[i % nu]
        n = n - np.dot(n, ti) * ti
        n /= np.linalg.norm(n)
        normals.append(n)
    n0, n_end = normals[0], normals[nu]
    twist = np.arctan2(np.dot(np.cross(n_end, n0), tan[0]), np.dot(n_end, n0))
    v = 2 * np.pi * np.arange(nv) / nv
    verts = []
    for i in range(nu):
        a = twist * i / nu
        ni = normals[i]
        bi = np.cross(tan[i], ni)
        ni, bi = np.cos(a) * ni + np.sin(a) * bi, -np.sin(a) * ni + np.cos(a) * bi
        ring = c[i] + radius * (np.cos(v)[:, None] * ni + np.sin(v)[:, None] * bi)
        verts.append(ring)
    verts = np.concatenate(verts)
    tris = periodic_grid_triangles(nu, nv)
    # Outward: the ring (cos v n + sin v b) with (t, n, b) right-handed turns the (u, v) order
    # around; check the signed volume and flip if needed.
    p = verts[tris]
    vol = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    if vol < 0:
        tris = tris[:, ::-1]
    return verts, tris


def read_ascii_stl(path):
    """Vertices welded exactly, as (vertices, triangles)."""
    pts = []
    for line in open(path):
        w = line.split()
        if w and w[0] == "vertex":
            pts.append([float(x) for x in w[1:4]])
    pts = np.array(pts)
    verts, inverse = np.unique(pts, axis=0, return_inverse=True)
    return verts, inverse.reshape(-1, 3)


def split_triangles(verts, tris):
    """Every triangle into 4 by its edge midpoints (shared midpoints welded): same surface, four
    times the triangles, still closed and consistently oriented."""
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    mids = 0.5 * (verts[uniq[:, 0]] + verts[uniq[:, 1]])
    m = inv.reshape(3, -1).T + len(verts)  # midpoint ids of (01, 12, 20)
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    ab, bc, ca = m[:, 0], m[:, 1], m[:, 2]
    new = np.concatenate([np.stack([a, ab, ca], -1), np.stack([ab, b, bc], -1),
                          np.stack([ca, bc, c], -1), np.stack([ab, bc, ca], -1)])
    return np.concatenate([verts, mids]), new


def write_binary_stl(path, verts, tris):
    data = np.zeros(len(tris), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    data["v"] = verts[tris]
    with open(path, "wb") as f:
        f.write(b"\0" * 80)
        f.write(np.uint32(len(tris)).tobytes())
        f.write(data.tobytes())


def box_surface(lo, hi):
    """An outward box, two triangles per face."""
    v = np.array([[(lo, hi)[i & 1][0], (lo, hi)[(i >> 1) & 1][1], (lo, hi)[(i >> 2) & 1][2]] for i in range(8)], float)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return v, np.array(tris)


def uv_sphere(nu, nv, radius=1.0, centre=(0.0, 0.0, 0.0)):
    """A closed, outward sphere of nu longitudes and nv latitude bands (poles welded)."""
    verts = [[0.0, 0.0, -radius]]
    for j in range(1, nv):
        th = np.pi * j / nv - np.pi / 2
        for i in range(nu):
            ph = 2 * np.pi * i / nu
            verts.append([radius * np.cos(th) * np.cos(ph), radius * np.cos(th) * np.sin(ph), radius * np.sin(th)])
    verts.append([0.0, 0.0, radius])
    verts = np.array(verts) + np.asarray(centre, dtype=float)
    top = len(verts) - 1
    ring = lambda j, i: 1 + (j - 1) * nu + i % nu
    tris = [[0, ring(1, i + 1), ring(1, i)] for i in range(nu)]
    for j in range(1, nv - 1):
        for i in range(nu):
            a, b, c, d = ring(j, i), ring(j, i + 1), ring(j + 1, i + 1), ring(j + 1, i)
            tris += [[a, b, c], [a, c, d]]
    tris += [[ring(nv - 1, i), ring(nv - 1, i + 1), top] for i in range(nu)]
    return verts, np.array(tris)


def signed_volume(verts, tris):
    p = verts[tris]
    return np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6


def winding_numbers(verts, tris, points, chunk=2048):
    """The generalized winding number of the triangles at each point, by brute force: the sum of
    the signed solid angles (Van Oosterom & Strackee) over 4 pi. Independent of the code under test."""
    out = np.empty(len(points))
    tri = verts[tris]
    for s in range(0, len(points), chunk):
        q = points[s:s + chunk, None, None, :]
        r = tri[None, :, :, :] - q                      # (P, T, 3, 3)
        a, b, c = r[..., 0, :], r[..., 1, :], r[..., 2, :]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        num = np.einsum("ptk,ptk->pt", a, np.cross(b, c))
        den = la * lb * lc + np.einsum("ptk,ptk->pt", a, b) * lc + np.einsum("ptk,ptk->pt", b, c) * la \
            + np.einsum("ptk,ptk->pt", c, a) * lb
        out[s:s + chunk] = (2 * np.arctan2(num, den)).sum(axis=1) / (4 * np.pi)
    return out


def revolve(profile, nu):
    """The closed surface of revolution about the x axis of a profile polyline [(x, r), ...] whose
    first and last points lie on the axis (r = 0, the poles): outward oriented when the profile
    runs from -x over the top to +x (the solid lies between it and the axis)."""
    profile = np.asarray(profile, float)
    ph = 2 * np.pi * np.arange(nu) / nu
    inner = profile[1:-1]
    verts = [[profile[0, 0], 0.0, 0.0]]
    for x, r in inner:
        verts += [[x, r * np.cos(p), r * np.sin(p)] for p in ph]
    verts.append([profile[-1, 0], 0.0, 0.0])
    n, top = len(inner), len(verts) - 1
    ring = lambda j, i: 1 + j * nu + i % nu
    tris = [[0, ring(0, i + 1), ring(0, i)] for i in range(nu)]
    for j in range(n - 1):
        for i in range(nu):
            a, b, c, d = ring(j, i), ring(j, i + 1), ring(j + 1, i + 1), ring(j + 1, i)
            tris += [[a, b, c], [a, c, d]]
    tris += [[ring(n - 1, i), ring(n - 1, i + 1), top] for i in range(nu)]
    return np.array(verts), np.array(tris)


def folded_spike(nu=32, nv=16):
    """A unit sphere with a spike along +x whose end is folded back over itself: the profile runs
    out along the neck to (1.5, 0.15), up to A = (2.5, 0.45), back to B = (2.0, 0.45) and down
    across its own outgoing segment to the tip (2.6, 0). Closed, consistently oriented, one
    self-intersection circle; the fold XAB is a ring traversed the other way, winding number -1,
    so it is outside. The pseudonormal of its top AB points into it, and every point whose
    nearest feature is AB, out to well beyond the sphere's y and z extent, takes the inside
    side."""
    th0 = np.arcsin(0.15)
    th = np.linspace(np.pi, th0, nv + 1)
    profile = [(np.cos(t), np.sin(t)) for t in th]
    profile[0] = (-1.0, 0.0)
    profile += [(1.5, 0.15), (2.5, 0.45), (2.0, 0.45), (2.5, 0.05), (2.6, 0.0)]
    return revolve(profile, nu)


def flip_every_third(tris):
    """The same closed surface with a third of its faces turned around (inconsistently oriented)."""
    out = tris.copy()
    out[::3] = out[::3, ::-1]
    return out


def punch_holes(verts, tris, centres, radius):
    """Drops every triangle whose centroid lies within `radius` of one of `centres`."""
    c = verts[tris].mean(axis=1)
    keep = np.ones(len(tris), bool)
    for p in centres:
        keep &= np.linalg.norm(c - np.asarray(p), axis=1) > radius
    return tris[keep]


def merge(*surfaces):
    """Several (verts, tris) as one soup (vertex ids offset, nothing welded)."""
    vs, ts, n = [], [], 0
    for v, t in surfaces:
        vs.append(v)
        ts.append(t + n)
        n += len(v)
    return np.concatenate(vs), np.concatenate(ts)


if __name__ == "__main__":
    import sys
    v, t = bumpy_torus(int(sys.argv[2]), int(sys.argv[3]))
    write_binary_stl(sys.argv[1], v, t)
