"""What `driver calibrate` leaves: calibration.json (every number, the curves' provenance),
calibration.md (the calibration table: each model's parameters, then target against achieved)
and plots/ (each calibration curve with the target and the chosen point marked)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from driver.calibration.material import MaterialFile
from runfiles.atomic import atomic_save, atomic_write_json, atomic_write_text

#: Parameter -> unit, for the tables.
UNITS = {"k_A": "u", "lambda_c": "", "theta_c_deg": "deg", "grain_diameter_in_a": "a",
         "kn": "N/m", "kt": "N/m", "kt_over_kn": "", "G_c": "J/m^2", "cell_size_m": "m",
         "length_a_m": "m", "mass_m_kg": "kg", "energy_u_J": "J", "time_tau_s": "s",
         "density": "kg/m^3", "E": "Pa", "nu": "", "K_IC": "Pa m^1/2"}
TITLES = {"bpm": "BPM (Clemmer-Robbins bonded particles)", "bcm": "BCM (bonded Voronoi cells)"}


def public(results: dict[str, Any]) -> dict[str, Any]:
    """The results without the in-memory curve arrays (for JSON)."""
    return {m: {k: v for k, v in r.items() if not k.startswith("_")} for m, r in results.items()}


def rows(result: dict[str, Any]) -> list[tuple[str, str, str]]:
    """(name, value, unit) of a model's parameters and units."""
    out = [(k, f"{v:.6g}", UNITS.get(k, "")) for k, v in result["parameters"].items()]
    out += [(k, f"{v:.6g}", UNITS.get(k, "")) for k, v in result.get("units", {}).items()]
    return out


def comparison(result: dict[str, Any]) -> list[tuple[str, str, str, str, str]]:
    """(property, target, achieved, relative difference, unit)."""
    out = []
    for k, t in result["target"].items():
        a = result["achieved"].get(k)
        if a is None:
            continue
        rel = "" if t == 0 else f"{(a - t) / abs(t):+.1%}"
        out.append((k, f"{t:.5g}", f"{a:.5g}", rel, UNITS.get(k, "")))
    return out


def reach_notes(result: dict[str, Any]) -> list[str]:
    return ([f"{name}: {r['note']}" for name, r in result["reach"].items() if r["note"]]
            + [f"warning: {n}" for n in result.get("notes", [])])


def markdown(mat: MaterialFile, results: dict[str, Any], source: str) -> str:
    t = mat.material
    lines = [f"# Calibration: {mat.name}", "", f"Material file: `{source}`. Target: density {t.density:g} kg/m^3, "
             f"E {t.E:.4g} Pa, nu {t.nu:g}, " + (f"G_c {t.G_c:g} J/m^2" if t.G_c is not None else
                                                f"K_IC {t.K_IC:.4g} Pa m^1/2") + ".", ""]
    for model, r in results.items():
        lines += [f"## {TITLES[model]}" + (f", {r['dimension']}D" if "dimension" in r else ""), "",
                  "| parameter | value | unit |", "|---|---|---|"]
        lines += [f"| {n} | {v} | {u} |" for n, v, u in rows(r)]
        lines += ["", "| property | target | achieved | difference | unit |", "|---|---|---|---|---|"]
        lines += [f"| {p} | {a} | {b} | {d} | {u} |" for p, a, b, d, u in comparison(r)]
        notes = reach_notes(r)
        lines += [""] + [f"- **out of reach**: {n}" if "out of reach" in n else f"- {n}" for n in notes]
        if r.get("verify"):
            lines += ["", "Round trip (the calibration tests run at these parameters):", "",
                      "| property | target | measured | difference |", "|---|---|---|---|"]
            lines += [f"| {k} | {v['target']:.5g} | {v['measured']:.5g} | {v['relative_error']:+.1%} |"
                      for k, v in r["verify"].items()]
        lines += ["", "Curves: " + ", ".join(f"`{c['directory']}`" + (" (cache)" if c["from_cache"] else "")
                                             for c in r["curves"].values()), ""]
    return "\n".join(lines) + "\n"


def plot_curves(results: dict[str, Any], plots: Path) -> list[Path]:
    """One figure per model: each curve, the target (dashed) and the chosen point."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    written = []
    for model, r in results.items():
        panels = r.get("_curves", {})
        if not panels:
            continue
        fig, axes = plt.subplots(1, len(panels), figsize=(4.5 * len(panels), 3.6), dpi=150, squeeze=False)
        for ax, c in zip(axes[0], panels.values()):
            ax.plot(c["x"], c["y"], "o-", label="measured")
            ax.axhline(c["target"], ls="--", color="k", lw=1, label="target")
            ax.plot([c["chosen"][0]], [c["chosen"][1]], "r*", ms=12,
                    label="chosen" if c["reached"] else "nearest reachable")
            ax.set(xlabel=c["xlabel"], ylabel=c["ylabel"])
            if c["log"]:
                ax.set(xscale="log", yscale="log")
            ax.legend(fontsize=7)
        fig.suptitle(TITLES[model], fontsize=9)
        fig.tight_layout()
        path = plots / f"{model}_curves.png"
        atomic_save(path, lambda p: fig.savefig(p))
        plt.close(fig)
        written.append(path)
    return written


def write_outputs(mat: MaterialFile, results: dict[str, Any], out: Path, source: str) -> dict[str, Path]:
    """calibration.json, calibration.md and the plots into `out` (atomic writes)."""
    out = Path(out)
    files = {"json": atomic_write_json(out / "calibration.json",
                                       {"name": mat.name, "material_file": source,
                                        "material": mat.model_dump(mode="json"), **public(results)}),
             "markdown": atomic_write_text(out / "calibration.md", markdown(mat, results, source))}
    for p in plot_curves(results, out / "plots"):
        files[p.stem] = p
    return files
