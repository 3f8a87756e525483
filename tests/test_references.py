"""References stay inside the repository. No file under core/, host/, kernels/, shaders/, tests/,
perf/, docs/, examples/ or cmake/, and no top-level README, CMakeLists.txt or setup.sh, may name
a file that lives outside it: the project's design and style pages, the notes/*.md digests or the
papers/*.txt texts of the shared folder, an absolute /work path, or a relative path that climbs
above the repository root. Facts the code relies on belong in docs/ (docs/README.md), and papers
are cited by name and section. Every docs/ page that a file names, and every Markdown link to a
.md file, must exist.

Checked on the real tree, and on copies of it with one deliberate bad reference of each kind,
which the check must refuse (as tests/test_layers.py does for the include direction)."""
import os
import pathlib
import re
import shutil
import tempfile
import unittest

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent

SCANNED_FOLDERS = ("core", "host", "kernels", "shaders", "tests", "perf", "docs", "examples", "cmake")
TOP_FILES = ("README.md", "CMakeLists.txt", "setup.sh")
SKIPPED = ("tests/data",)  # test models and installed packages, not the project's prose
MAX_BYTES = 1 << 20

# Each pattern names a file outside the repository. The sources below are written so that they
# do not match themselves (a character class or an escape sits inside every literal).
OUTSIDE = (
    (re.compile(r"\b(?:DESIGN|STYLE)\.md\b"), "the shared design/style pages are outside the repository"),
    (re.compile(r"\bnotes/[\w.-]+\.md\b"), "the shared notes are outside the repository"),
    (re.compile(r"\bpapers/[\w.-]+\.txt\b"), "the paper texts are outside the repository; cite the paper by name and section"),
    (re.compile(r"(?:\.\./)+shared\b|\bshared/(?:notes|papers)\b"), "the shared folder is outside the repository"),
    (re.compile(r"/work/[\w.-]+"), "an absolute path of the development machine"),
    (re.compile(r"\bthe design[ ]notes\b", re.I), "that text lives outside the repository; point to docs/"),
)
DOCS_PAGE = re.compile(r"(?<![\w./-])docs/([\w.-]+\.md)\b")
MARKDOWN_LINK = re.compile(r"\]\(([\w./-]+\.md)(?:#[\w-]*)?\)")
CLIMB = re.compile(r"(?<![\w.])((?:\.\./)+)")


def scanned_files(root):
    root = pathlib.Path(root)
    for name in TOP_FILES:
        if (root / name).is_file():
            yield root / name
    for top in SCANNED_FOLDERS:
        for dirpath, dirnames, filenames in os.walk(root / top):
            rel_dir = pathlib.Path(dirpath).relative_to(root).as_posix()
            dirnames[:] = sorted(d for d in dirnames
                                 if f"{rel_dir}/{d}" not in SKIPPED and d != "__pycache__")
            for f in sorted(filenames):
                yield pathlib.Path(dirpath) / f


def read_text(path):
    """The file as text, or None for a binary or very large file."""
    if path.stat().st_size > MAX_BYTES:
        return None
    data = path.read_bytes()
    if b"\0" in data:
        return None
    return data.decode("utf-8", errors="replace")


def violations(root):
    root = pathlib.Path(root).resolve()
    out = []
    for path in scanned_files(root):
        text = read_text(path)
        if text is None:
            continue
        rel = path.relative_to(root).as_posix()
        depth = rel.count("/")  # folders between the root and the file

        def where(m):
            return f"{rel}:{text.count(chr(10), 0, m.start()) + 1}"

        for pattern, why in OUTSIDE:
            for m in pattern.finditer(text):
                out.append(f"{where(m)}: names {m.group(0)} ({why})")
        for m in DOCS_PAGE.finditer(text):
            if not (root / "docs" / m.group(1)).is_file():
                out.append(f"{where(m)}: names docs/{m.group(1)}, which does not exist")
        if path.suffix == ".md":
            for m in MARKDOWN_LINK.finditer(text):
                if not (path.parent / m.group(1)).resolve().is_file():
                    out.append(f"{where(m)}: links to {m.group(1)}, which does not exist")
        for m in CLIMB.finditer(text):
            if m.group(1).count("../") > depth:
                climbed = text[m.start():].split(None, 1)[0]
                out.append(f"{where(m)}: the path {climbed} climbs out of the repository")
    return sorted(out)


def skipped_in_copy(folder, names):
    rel = pathlib.Path(folder).resolve().relative_to(ROOT).as_posix()
    return [n for n in names if n == "__pycache__" or f"{rel}/{n}" in SKIPPED]


class ReferencesTest(unittest.TestCase):
    def copy_tree(self):
        tmp = pathlib.Path(tempfile.mkdtemp())
        self.addCleanup(shutil.rmtree, tmp)
        for top in SCANNED_FOLDERS:
            if (ROOT / top).is_dir():
                shutil.copytree(ROOT / top, tmp / top, symlinks=True, ignore=skipped_in_copy)
        for name in TOP_FILES:
            if (ROOT / name).is_file():
                shutil.copy(ROOT / name, tmp / name)
        return tmp

    def expect_refused(self, root, *needles):
        found = violations(root)
        self.assertTrue(found, "a bad reference was not refused")
        text = "\n".join(found)
        for n in needles:
            self.assertIn(n, text)
        return found

    def append(self, path, text):
        path.write_text(path.read_text() + text)

    def test_the_tree_points_only_inside_itself(self):
        found = violations(ROOT)
        self.assertEqual(found, [], "\n".join(found))

    def test_the_docs_pages_exist(self):
        for page in ("README.md", "pipeline.md", "mc33.md", "templates.md", "backends.md"):
            self.assertTrue((ROOT / "docs" / page).is_file(), page)

    def test_a_comment_naming_the_design_page_fails(self):
        tmp = self.copy_tree()
        self.append(tmp / "core/cutting/mc33.h", "// zeros are perturbed first (" + "DESIGN" + ".md)\n")
        found = self.expect_refused(tmp, "core/cutting/mc33.h:", "names DESIGN" + ".md")
        self.assertEqual(len(found), 1, found)

    def test_a_comment_naming_a_shared_note_fails(self):
        tmp = self.copy_tree()
        self.append(tmp / "tests/test_mc33.cpp", "// facts of " + "notes" + "/mc33-topology.md\n")
        self.expect_refused(tmp, "tests/test_mc33.cpp:", "the shared notes")

    def test_a_paper_path_fails(self):
        tmp = self.copy_tree()
        self.append(tmp / "kernels/sdf.h", "// see " + "papers" + "/mchex-tong-zhang-2025.txt\n")
        self.expect_refused(tmp, "kernels/sdf.h:", "cite the paper by name and section")

    def test_the_shared_folder_and_absolute_paths_fail(self):
        tmp = self.copy_tree()
        self.append(tmp / "shaders/README.md", "\nBackground: " + ".." + "/shared/x.md\n")
        self.append(tmp / "perf/run.sh", "# " + "/work" + "/elsewhere/model.stl\n")
        self.expect_refused(tmp, "shaders/README.md:", "perf/run.sh:", "absolute path")

    def test_the_design_notes_in_words_fail(self):
        tmp = self.copy_tree()
        self.append(tmp / "host/backends/cpu.h", "// as the design " + "notes say\n")
        self.expect_refused(tmp, "host/backends/cpu.h:", "point to docs/")

    def test_a_missing_docs_page_fails(self):
        tmp = self.copy_tree()
        self.append(tmp / "core/grid/octree.h", "// (" + "docs/" + "no_such_page.md)\n")
        self.append(tmp / "README.md", "\nSee [the page](" + "docs/" + "gone.md).\n")
        self.expect_refused(tmp, "core/grid/octree.h:", "no_such_page.md, which does not exist",
                            "README.md:", "gone.md, which does not exist")

    def test_a_broken_link_between_docs_pages_fails(self):
        tmp = self.copy_tree()
        self.append(tmp / "docs/README.md", "\n[old](" + "design" + ".md)\n")
        self.expect_refused(tmp, "docs/README.md:", "links to design" + ".md")

    def test_a_path_that_climbs_out_fails(self):
        tmp = self.copy_tree()
        # perf/ is one folder deep: one step up stays inside, two leave the repository.
        self.append(tmp / "perf/run.sh", '# models: "$here/' + '..' + '/tests/data" is fine\n')
        self.assertEqual(violations(tmp), [])
        self.append(tmp / "perf/run.sh", '# cp "$here/' + '../..' + '/elsewhere/model.stl"\n')
        self.expect_refused(tmp, "perf/run.sh:", "climbs out of the repository")

    def test_a_top_level_readme_is_checked(self):
        tmp = self.copy_tree()
        self.append(tmp / "README.md", "\nStyle: " + "STYLE" + ".md\n")
        self.expect_refused(tmp, "README.md:", "names STYLE" + ".md")


if __name__ == "__main__":
    unittest.main()
