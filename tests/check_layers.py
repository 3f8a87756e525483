"""The include-direction check: every #include "core/..." or "host/..." in the project's C++ must
name the file's own stage folder or one it builds on, as the build states it
(${build}/layers.txt, written by mchex_layer in CMakeLists.txt: "folder: dependency ...").
Files under core/ and host/ must sit in a stage folder. tests/ and perf/ may include anything.

Usage: check_layers.py LAYERS_FILE SOURCE_ROOT     (exit 0: clean; 1: each violation on a line)"""
import pathlib
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s+"((?:core|host)/[^"]+)"', re.M)
SOURCES = (".h", ".hpp", ".cpp", ".cc")


def read_layers(path):
    deps = {}
    for line in pathlib.Path(path).read_text().splitlines():
        if line.strip():
            folder, _, rest = line.partition(":")
            deps[folder.strip()] = rest.split()
    return deps


def closure(deps):
    """Each stage folder with every folder it may include: itself and its dependencies, transitively."""
    allowed = {}

    def visit(folder, path=()):
        if folder in allowed:
            return allowed[folder]
        if folder in path:
            raise SystemExit(f"layers: dependency cycle through {folder}")
        out = {folder}
        for d in deps.get(folder, []):
            if d not in deps:
                raise SystemExit(f"layers: {folder} depends on {d}, which is no stage")
            out |= visit(d, path + (folder,))
        allowed[folder] = out
        return out

    for folder in deps:
        visit(folder)
    return allowed


def stage_of(rel, stages):
    """The stage folder a path belongs to (the longest stage folder that contains it), or None."""
    best = None
    for s in stages:
        if rel.startswith(s + "/") and (best is None or len(s) > len(best)):
            best = s
    return best


def violations(layers_file, root):
    deps = read_layers(layers_file)
    allowed = closure(deps)
    root = pathlib.Path(root)
    out = []
    for top in ("core", "host"):
        for path in sorted((root / top).rglob("*")):
            if path.suffix not in SOURCES or not path.is_file():
                continue
            rel = path.relative_to(root).as_posix()
            own = stage_of(rel, deps)
            if own is None:
                out.append(f"{rel}: not in a stage folder ({', '.join(sorted(deps))})")
                continue
            text = path.read_text(errors="replace")
            for m in INCLUDE.finditer(text):
                target = m.group(1)
                line = text.count("\n", 0, m.start()) + 1
                to = stage_of(target, deps)
                if to is None:
                    out.append(f"{rel}:{line}: includes {target}, which is in no stage folder")
                elif to not in allowed[own]:
                    out.append(f"{rel}:{line}: {own} includes {target} ({to} is not below {own})")
    return out


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    found = violations(argv[1], argv[2])
    for v in found:
        print(v)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
