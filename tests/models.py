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


if __name__ == "__main__":
    import sys
    v, t = bumpy_torus(int(sys.argv[2]), int(sys.argv[3]))
    write_binary_stl(sys.argv[1], v, t)
