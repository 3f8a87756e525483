"""Our mesh files checked against meshio, an independent reader and writer (Debian's
python3-meshio 7.0.0-3, which calls itself 5.0.0).

Formats: .mesh, .meshb, .vtu, .msh (ascii and binary), .exo and .inp. Both directions go through
the gtest binary test_mesh_io (beside the CLI in the build tree):
  - its HexmeshSamples.WriteSamples test writes the sample mesh in every format with our writer;
    meshio reads them and they must hold the sample, rebuilt here independently, with
    bit-identical points (.inp: within CalculiX's 20-character fields). meshio's Exodus reader
    keeps the blocks and node sets but neither block ids, names, the element number map nor side
    sets, so those are read from the file with netCDF4 (the library meshio reads it with) and
    checked against faces found here by brute force;
  - meshio writes the sample (and variants with surface cells, several blocks, other byte layouts)
    in every format; `mchex-gpu convert` reads each with our reader and writes it back as
    .vtu, which meshio reads again for the comparison.

ctest runs this from tests/ with MCHEX_GPU set to the CLI; MCHEX_TEST_MESH_IO may name the gtest
binary directly.
"""

import os
import subprocess
import tempfile
import unittest

import meshio  # Debian's python3-meshio; tests/CMakeLists.txt runs /usr/bin/python3
import netCDF4  # Debian's python3-netcdf4: meshio's Exodus reader needs it
import numpy as np

# The Exodus II HEX8 sides as 0-based corners, from the Exodus II manual's side numbering
# (Schoof & Yarberry 1994, the hexahedron figure): side 1 is the face of nodes 1-2-6-5, ...
EXODUS_HEX_SIDES = [[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [0, 4, 7, 3], [0, 3, 2, 1], [4, 5, 6, 7]]


def faces_of(hexes):
    """Every face of every hex as (sorted corner tuple) -> list of (hex, face corners)."""
    faces = {}
    for h, hexa in enumerate(hexes):
        for side in EXODUS_HEX_SIDES:
            faces.setdefault(tuple(sorted(hexa[side])), []).append(h)
    return faces


def sample():
    """The mesh of sample_mesh() in test_mesh_io.cpp, built from its description."""
    points = [[i / 3.0, j * 0.1, float(k)] for k in range(3) for j in range(3) for i in range(3)]
    points[0] = [-0.0, 1e-17, 1.0 / 3.0]
    points[4][0] = 1e300
    points[13] = [5e-324, -1.7976931348623157e308, 0.1 + 0.2]
    points[26][2] = -2.2250738585072014e-308
    hexes = []
    for k in range(2):
        for j in range(2):
            for i in range(2):
                b = i + 3 * j + 9 * k
                # VTK_HEXAHEDRON: bottom face counter-clockwise seen from +z, then the top face.
                hexes.append([b, b + 1, b + 4, b + 3, b + 9, b + 10, b + 13, b + 12])
    regions = [1, 2, 2, 1, 3, 1, 1, 2]
    return (np.array(points, dtype=np.float64), np.array(hexes, dtype=np.int64),
            np.array(regions, dtype=np.int64))


def gtest_binary():
    explicit = os.environ.get("MCHEX_TEST_MESH_IO")
    if explicit:
        return explicit
    cli = os.environ.get("MCHEX_GPU")
    if cli:
        return os.path.normpath(os.path.join(os.path.dirname(cli), "..", "tests", "test_mesh_io"))
    return None


class MeshioFormats(unittest.TestCase):
    def setUp(self):
        self.binary = gtest_binary()
        if self.binary is None:
            self.skipTest("MCHEX_GPU (or MCHEX_TEST_MESH_IO) is not set: run through ctest")
        self.assertTrue(os.access(self.binary, os.X_OK), f"no test binary at {self.binary}")
        self.tmp = tempfile.TemporaryDirectory(prefix="mchex_meshio_")
        self.addCleanup(self.tmp.cleanup)

    def folder(self, name):
        path = os.path.join(self.tmp.name, name)
        os.makedirs(path)
        return path

    def run_gtest(self, name, **env):
        result = subprocess.run(
            [self.binary, f"--gtest_filter=HexmeshSamples.{name}"],
            env=dict(os.environ, **env), capture_output=True, text=True, timeout=300)
        output = result.stdout + result.stderr
        self.assertEqual(result.returncode, 0, output)
        self.assertIn("[  PASSED  ] 1 test", output, output)

    def assert_points_exact(self, got, expected):
        self.assertEqual(got.dtype, np.float64)
        self.assertEqual(got.shape, expected.shape)
        # Compare bit patterns: -0.0 == 0.0 would hide a lost sign.
        np.testing.assert_array_equal(np.ascontiguousarray(got).view(np.uint64), expected.view(np.uint64))

    def hexes_of(self, mesh, key):
        """Hexahedra and their labels in file order; every other cell type is a failure."""
        hexes, labels = [], []
        for block, data in zip(mesh.cells, mesh.cell_data[key]):
            self.assertEqual(block.type, "hexahedron")
            hexes.append(block.data)
            labels.append(data)
        return np.concatenate(hexes), np.concatenate(labels)

    def test_meshio_reads_what_we_write(self):
        out = self.folder("ours")
        self.run_gtest("WriteSamples", MCHEX_MESHIO_OUT=out)
        points, hexes, regions = sample()

        mesh = meshio.read(os.path.join(out, "sample.mesh"))
        self.assert_points_exact(mesh.points, points)
        got_hexes, got_regions = self.hexes_of(mesh, "medit:ref")
        np.testing.assert_array_equal(got_hexes, hexes)
        np.testing.assert_array_equal(got_regions, regions)
        np.testing.assert_array_equal(mesh.point_data["medit:ref"], np.zeros(len(points)))

        mesh = meshio.read(os.path.join(out, "sample.vtu"))
        self.assert_points_exact(mesh.points, points)
        got_hexes, got_regions = self.hexes_of(mesh, "region")
        np.testing.assert_array_equal(got_hexes, hexes)
        np.testing.assert_array_equal(got_regions, regions)
        self.assertEqual(got_regions.dtype, np.int32)

        mesh = meshio.read(os.path.join(out, "sample.msh"))
        self.assert_points_exact(mesh.points, points)
        got_hexes, got_regions = self.hexes_of(mesh, "gmsh:physical")
        np.testing.assert_array_equal(got_hexes, hexes)
        np.testing.assert_array_equal(got_regions, regions)
        # Entity tags equal the regions when those are positive.
        np.testing.assert_array_equal(self.hexes_of(mesh, "gmsh:geometrical")[1], regions)
        self.assertEqual({name: list(v) for name, v in mesh.field_data.items()},
                         {f"region_{r}": [r, 3] for r in (1, 2, 3)})

        # Gmsh 4.1 binary: the same content.
        mesh = meshio.read(os.path.join(out, "sample_binary.msh"))
        self.assert_points_exact(mesh.points, points)
        got_hexes, got_regions = self.hexes_of(mesh, "gmsh:physical")
        np.testing.assert_array_equal(got_hexes, hexes)
        np.testing.assert_array_equal(got_regions, regions)

        # MEDIT binary.
        mesh = meshio.read(os.path.join(out, "sample.meshb"))
        self.assert_points_exact(mesh.points, points)
        got_hexes, got_regions = self.hexes_of(mesh, "medit:ref")
        np.testing.assert_array_equal(got_hexes, hexes)
        np.testing.assert_array_equal(got_regions, regions)

        self.check_abaqus(os.path.join(out, "sample.inp"), points, hexes, regions)
        self.check_exodus(os.path.join(out, "sample.exo"), points, hexes, regions)

    def check_abaqus(self, path, points, hexes, regions):
        """One C3D8 block of every hex in order; an element set REGIONr per region."""
        mesh = meshio.read(path)
        # Coordinates whose shortest form is over 20 characters are rounded to fit.
        np.testing.assert_allclose(mesh.points, points, rtol=5e-13, atol=0)
        self.assertEqual([b.type for b in mesh.cells], ["hexahedron"])
        np.testing.assert_array_equal(mesh.cells[0].data, hexes)
        got = np.full(len(hexes), -999)
        for name, (members,) in mesh.cell_sets.items():
            self.assertTrue(name.startswith("REGION"), name)
            self.assertTrue(np.all(got[members] == -999), "a hex in two region sets")
            got[members] = int(name[6:])
        np.testing.assert_array_equal(got, regions)

    def check_exodus(self, path, points, hexes, regions):
        """Blocks per region in ascending order, the number map back to our hex order, the boundary
        node set, a side set per pair of regions sharing faces."""
        mesh = meshio.read(path)
        self.assert_points_exact(mesh.points, points)
        order = np.argsort(regions, kind="stable")
        self.assertEqual([b.type for b in mesh.cells], ["hexahedron"] * len(set(regions)))
        np.testing.assert_array_equal(np.concatenate([b.data for b in mesh.cells]), hexes[order])
        faces = faces_of(hexes)
        boundary = sorted({v for key, hs in faces.items() if len(hs) == 1 for v in key})
        np.testing.assert_array_equal(mesh.point_sets["boundary"], boundary)

        def names(nc, variable):
            return [b"".join(row).decode().rstrip("\x00") for row in nc.variables[variable][:].filled(b"")]

        with netCDF4.Dataset(path) as nc:
            ids = list(nc.variables["eb_prop1"][:])
            self.assertEqual(ids, sorted(set(regions.tolist())))
            self.assertEqual(names(nc, "eb_names"), [f"region_{r}" for r in ids])
            number = np.asarray(nc.variables["elem_num_map"][:]) - 1
            np.testing.assert_array_equal(number, order)
            expected = {}
            for key, hs in faces.items():
                if len(hs) == 2 and regions[hs[0]] != regions[hs[1]]:
                    a, b = sorted((regions[hs[0]], regions[hs[1]]))
                    expected.setdefault(f"interface_{a}_{b}", set()).add(key)
            got = {}
            for k, name in enumerate(names(nc, "ss_names")):
                elements = np.asarray(nc.variables[f"elem_ss{k + 1}"][:]) - 1
                sides = np.asarray(nc.variables[f"side_ss{k + 1}"][:]) - 1
                a = int(name.split("_")[1])
                for e, side in zip(elements, sides):
                    h = number[e]
                    self.assertEqual(regions[h], a, "the side's element is the lower region's")
                    got.setdefault(name, set()).add(tuple(sorted(hexes[h][EXODUS_HEX_SIDES[side]])))
            self.assertEqual(got, expected)

    def test_we_read_what_meshio_writes(self):
        points, hexes, regions = sample()
        quads = np.array([[0, 1, 4, 3], [1, 2, 5, 4]])
        files = {}  # file name -> (expected points, hexes, regions, exact points?)

        def save(name, mesh, expected_hexes=hexes, expected_regions=regions, exact=True, **options):
            meshio.write(os.path.join(inputs, name), mesh, **options)
            files[name] = (points, expected_hexes, expected_regions, exact)

        inputs = self.folder("meshio")
        hex_only = [("hexahedron", hexes)]
        save("medit.mesh", meshio.Mesh(points, hex_only, cell_data={"medit:ref": [regions]}),
             file_format="medit")
        # Surface cells beside the hexes: written as Quadrilaterals and Edges, which we skip.
        save("medit_surface.mesh",
             meshio.Mesh(points, [("quad", quads), ("hexahedron", hexes), ("line", quads[:, :2])],
                         cell_data={"medit:ref": [np.array([7, 8]), regions, np.array([5, 6])]}),
             file_format="medit")
        save("binary.vtu",
             meshio.Mesh(points, hex_only, cell_data={"region": [regions.astype(np.int32)]}),
             file_format="vtu", binary=True, compression=None)
        # Quads between the hexes, Int64 labels, UInt32 block headers (meshio's defaults).
        save("mixed.vtu",
             meshio.Mesh(points, [("hexahedron", hexes[:3]), ("quad", quads), ("hexahedron", hexes[3:])],
                         cell_data={"region": [regions[:3], np.array([7, 8]), regions[3:]]}),
             file_format="vtu", binary=True, compression=None)
        # meshio's ascii VTU keeps 12 significant digits only.
        save("ascii.vtu",
             meshio.Mesh(points, hex_only, cell_data={"region": [regions.astype(np.int32)]}),
             exact=False, file_format="vtu", binary=False)
        # One hex block, no $Entities: the entity tag is the region.
        save("single.msh",
             meshio.Mesh(points, hex_only, cell_data={"gmsh:geometrical": [np.full(len(hexes), 5)],
                                                      "gmsh:physical": [np.full(len(hexes), 5)]}),
             expected_regions=np.full(len(hexes), 5), file_format="gmsh", binary=False)
        # One block per region (meshio wants a distinct entity per block), entities 11..13 with
        # the regions as physical tags, a quad block on a surface entity, nodes spread over the
        # entities so that the node blocks are not in point order, physical names.
        order = np.argsort(regions, kind="stable")
        blocks = [("quad", quads)] + [("hexahedron", hexes[regions == r]) for r in (1, 2, 3)]
        dim_tags = np.array([[3, 11 + i % 3] for i in range(len(points))])
        dim_tags[0] = [2, 7]
        save("blocks.msh",
             meshio.Mesh(points, blocks,
                         point_data={"gmsh:dim_tags": dim_tags},
                         cell_data={"gmsh:geometrical": [np.full(len(b[1]), t) for b, t in zip(blocks, (7, 11, 12, 13))],
                                    "gmsh:physical": [np.full(len(b[1]), t) for b, t in zip(blocks, (9, 1, 2, 3))]},
                         field_data={"wall": np.array([9, 2]), "one": np.array([1, 3]),
                                     "two": np.array([2, 3]), "three": np.array([3, 3])}),
             expected_hexes=hexes[order], expected_regions=regions[order], file_format="gmsh", binary=False)

        save("binary.meshb", meshio.Mesh(points, hex_only, cell_data={"medit:ref": [regions]}), file_format="medit")
        # meshio's binary Gmsh writer wants a distinct entity per block, as above.
        save("blocks_binary.msh",
             meshio.Mesh(points, blocks[1:], point_data={"gmsh:dim_tags": np.array([[3, 11 + i % 3] for i in range(len(points))])},
                         cell_data={"gmsh:geometrical": [np.full(len(b[1]), t) for b, t in zip(blocks[1:], (11, 12, 13))],
                                    "gmsh:physical": [np.full(len(b[1]), t) for b, t in zip(blocks[1:], (1, 2, 3))]}),
             expected_hexes=hexes[order], expected_regions=regions[order], file_format="gmsh", binary=True)
        # Element sets REGIONr give the regions; meshio's 16-digit coordinates are over 20
        # characters but parse exactly.
        save("sets.inp",
             meshio.Mesh(points, hex_only,
                         cell_sets={f"REGION{r}": [np.flatnonzero(regions == r)] for r in (1, 2, 3)}),
             file_format="abaqus")
        # meshio's Exodus (netCDF-4): one block per region; without names the region is the block
        # id, which meshio numbers 0, 1, 2.
        save("blocks.exo", meshio.Mesh(points, blocks[1:]), expected_hexes=hexes[order],
             expected_regions=regions[order] - 1, file_format="exodus")

        out = self.folder("converted")
        for name in sorted(os.listdir(inputs)):
            r = subprocess.run([os.environ["MCHEX_GPU"], "convert", os.path.join(inputs, name),
                                os.path.join(out, name + ".vtu")], capture_output=True, text=True, timeout=300)
            self.assertEqual(r.returncode, 0, name + ": " + r.stderr)
        self.assertEqual(sorted(os.listdir(out)), sorted(name + ".vtu" for name in files))
        for name, (expected_points, expected_hexes, expected_regions, exact) in files.items():
            with self.subTest(name):
                mesh = meshio.read(os.path.join(out, name + ".vtu"))
                if exact:
                    self.assert_points_exact(mesh.points, expected_points)
                else:
                    np.testing.assert_allclose(mesh.points, expected_points, rtol=1e-11, atol=0)
                got_hexes, got_regions = self.hexes_of(mesh, "region")
                np.testing.assert_array_equal(got_hexes, expected_hexes)
                np.testing.assert_array_equal(got_regions, expected_regions)


    def test_convert_handles_every_pair(self):
        """`mchex-gpu convert` from each format to each other one keeps points, hexes and regions
        (the .inp leg rounds what CalculiX's fields cannot hold), as meshio reads the end result."""
        out = self.folder("ours")
        self.run_gtest("WriteSamples", MCHEX_MESHIO_OUT=out)
        points, hexes, regions = sample()
        sources = ["sample.mesh", "sample.meshb", "sample.vtu", "sample.msh", "sample_binary.msh", "sample.exo",
                   "sample.inp"]
        targets = [(".mesh", []), (".meshb", []), (".vtu", []), (".msh", []), (".msh", ["--binary"]), (".exo", []),
                   (".inp", [])]
        work = self.folder("pairs")
        for source in sources:
            for k, (extension, flags) in enumerate(targets):
                with self.subTest(source=source, target=extension + " ".join(flags)):
                    middle = os.path.join(work, f"{source}.{k}{extension}")
                    final = middle + ".vtu"
                    for a, b, f in ((os.path.join(out, source), middle, flags), (middle, final, [])):
                        r = subprocess.run([os.environ["MCHEX_GPU"], "convert", a, b, *f], capture_output=True,
                                           text=True, timeout=300)
                        self.assertEqual(r.returncode, 0, r.stderr)
                    mesh = meshio.read(final)
                    if extension == ".inp" or source == "sample.inp":
                        np.testing.assert_allclose(mesh.points, points, rtol=5e-13, atol=0)
                    else:
                        self.assert_points_exact(mesh.points, points)
                    got_hexes, got_regions = self.hexes_of(mesh, "region")
                    np.testing.assert_array_equal(got_hexes, hexes)
                    np.testing.assert_array_equal(got_regions, regions)

    def test_bad_files_are_one_line(self):
        """A malformed file of each new format: exit 1, one stderr line naming the file, no output."""
        work = self.folder("bad")
        cases = {"bad.meshb": b"\x01\x00\x00\x00\x03\x00\x00\x00", "bad.exo": b"CDF\x01garbage",
                 "bad.inp": b"*NODE\n1,0,0\n*ELEMENT, TYPE=C3D8\n1,1,1,1,1,1,1,1,2\n",
                 "bad.msh": b"$MeshFormat\n4.1 1 8\n\x01\x00\x00\x00\n$EndMeshFormat\n$Nodes\n\x05"}
        for name, content in cases.items():
            with self.subTest(name):
                path = os.path.join(work, name)
                with open(path, "wb") as f:
                    f.write(content)
                r = subprocess.run([os.environ["MCHEX_GPU"], "convert", path, os.path.join(work, "out.vtu")],
                                   capture_output=True, text=True, timeout=60)
                self.assertEqual(r.returncode, 1, r.stderr)
                self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
                self.assertIn(path, r.stderr)
                self.assertFalse(os.path.exists(os.path.join(work, "out.vtu")))


if __name__ == "__main__":
    unittest.main()
