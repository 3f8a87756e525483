"""Test models the packages do not have: closed, consistently oriented surfaces of any size,
written as binary STL with numpy (independent of the code under test)."""
import numpy as np


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
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return verts, tris


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
