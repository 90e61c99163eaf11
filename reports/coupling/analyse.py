"""The coupling study's analysis, as declared in README.md: coupling by set (A1) and conditional detection rates (A2).

    python reports/coupling/analyse.py --new results/coupling/report/kill_matrix.csv --out reports/coupling

Reads the committed kill matrices of the strategies study's two halves and the campaign's (``--new``), checks
that the campaign reproduces the committed verdicts of the fault it reruns, and writes ``coupling.csv`` (A1),
``rates.csv`` (A2) and ``cases.csv`` (per case: which real faults it detects, its kill share of each fault's
unit mutants and its detection share of the injected faults).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import fisher_exact
from statsmodels.stats.multitest import multipletests
from statsmodels.stats.proportion import confint_proportions_2indep, proportion_confint

from faultlab.faults.real import REAL_FAULTS
from faultlab.stats.killmatrix import KillMatrix, strong_cases

HERE = Path(__file__).resolve().parent
REPORTS = HERE.parent
KEY = ["strategy", "run", "case"]
ALPHA = 0.05
RERUN = "new_landmark_near_zero"


def detections(path: Path) -> pd.DataFrame:
    """Per (case, variant): detected by the single-case rule (crash, or p <= 0.05), as a cases x variants frame."""
    km = KillMatrix.from_frame(pd.read_csv(path))
    strong = strong_cases(km, 1, alpha=ALPHA)
    frame = pd.DataFrame(strong, columns=list(km.variants))
    return pd.concat([km.cases, frame], axis=1).set_index(KEY)


def _unit(variant: str) -> str:
    return variant.split(":")[1].split(".")[0]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--new", required=True, help="the campaign's kill_matrix.csv")
    ap.add_argument("--out", default=str(HERE))
    args = ap.parse_args()
    out = Path(args.out)

    mutants = detections(REPORTS / "study-large-mutants" / "kill_matrix.csv")
    faults_all = detections(REPORTS / "study-large-faults" / "kill_matrix.csv")
    faults = faults_all.loc[mutants.index]
    new = detections(Path(args.new)).loc[mutants.index]
    assert len(mutants) == 174 and len(new) == 174

    # the campaign reproduces the committed verdicts of the fault it reruns, exactly
    committed = pd.read_csv(REPORTS / "study-large-faults" / "kill_matrix.csv").set_index(KEY + ["variant"])
    rerun = pd.read_csv(args.new).set_index(KEY + ["variant"])
    a = committed.xs(RERUN, level="variant").loc[mutants.index]
    b = rerun.xs(RERUN, level="variant").loc[mutants.index]
    same_p = np.array_equal(a["p"].to_numpy(), b["p"].to_numpy(), equal_nan=True)
    same_crash = np.array_equal(a["crash"].to_numpy(), b["crash"].to_numpy())
    if not (same_p and same_crash):
        raise SystemExit(f"the campaign does not reproduce the committed verdicts of {RERUN}: not joined")

    real = {r.name: r.fault for r in REAL_FAULTS if r.fault is not None}
    detect = pd.DataFrame({name: (new[name] if name in new.columns and name != RERUN else faults[name])
                           for name in real})
    injected = [v for v in faults.columns if v not in real]
    injected_detectable = [v for v in injected if faults[v].any()]
    mutant_cols = [v for v in mutants.columns if v.startswith("mutant:")]
    killable = [v for v in mutant_cols if mutants[v].any()]

    coupling_rows, rate_rows, case_cols = [], [], {}
    for name, fault in real.items():
        d = detect[name].to_numpy(bool)
        m_unit = [v for v in killable if _unit(v) == fault.step]
        groups = {"unit mutants": m_unit, "all mutants": killable, "injected faults": injected_detectable}
        for label, cols in groups.items():
            matrix = (mutants if "mutants" in label else faults)[cols].to_numpy(bool)
            if not cols:
                coupling_rows.append({"real_fault": name, "unit": fault.step, "against": label, "n_targets": 0,
                                      "coupled": "not judged", "n_missing_cases": int((~d).sum()),
                                      "targets_missed_cases_cannot_kill": "", "n_forcing": 0})
                continue
            missed_kill = matrix[~d].any(axis=0)  # what the cases missing f kill between them
            forcing = [c for c, k in zip(cols, missed_kill) if not k]  # killed only by cases detecting f
            coupling_rows.append({"real_fault": name, "unit": fault.step, "against": label, "n_targets": len(cols),
                                  "coupled": "yes" if forcing else "no", "n_missing_cases": int((~d).sum()),
                                  "targets_missed_cases_cannot_kill": " ".join(forcing[:8])
                                  + (f" (+{len(forcing) - 8} more)" if len(forcing) > 8 else ""),
                                  "n_forcing": len(forcing)})
            if label == "all mutants":
                continue
            share = matrix.mean(axis=1)
            case_cols[f"{name}: {label} share"] = share
            kills = share >= 0.5
            row = {"real_fault": name, "unit": fault.step, "condition": f"{label}: at least half of {len(cols)}"}
            for tag, mask in (("kills", kills), ("not", ~kills)):
                n, k = int(mask.sum()), int(d[mask].sum())
                row[f"n_{tag}"], row[f"detect_{tag}"] = n, k
                if n:
                    lo, hi = proportion_confint(k, n, alpha=ALPHA, method="beta")
                    row[f"p_{tag}"], row[f"p_{tag}_lo"], row[f"p_{tag}_hi"] = k / n, lo, hi
            if row["n_kills"] and row["n_not"]:
                table = [[row["detect_kills"], row["n_kills"] - row["detect_kills"]],
                         [row["detect_not"], row["n_not"] - row["detect_not"]]]
                row["fisher_p"] = fisher_exact(table, alternative="two-sided").pvalue
                lo, hi = confint_proportions_2indep(row["detect_kills"], row["n_kills"], row["detect_not"],
                                                    row["n_not"], method="newcomb", compare="diff", alpha=ALPHA)
                row["diff"], row["diff_lo"], row["diff_hi"] = row["p_kills"] - row["p_not"], lo, hi
            rate_rows.append(row)
        case_cols[f"{name}: detected"] = d

    rates = pd.DataFrame(rate_rows)
    for col in ("p_kills", "p_kills_lo", "p_kills_hi", "p_not", "p_not_lo", "p_not_hi", "fisher_p", "diff", "diff_lo",
                "diff_hi", "holm_p"):
        rates[col] = rates[col] if col in rates else np.nan
    rates["verdict"] = ""
    for label in ("unit mutants", "injected faults"):
        sel = rates["condition"].str.startswith(label) & rates["fisher_p"].notna()
        if sel.any():
            reject, adj, _, _ = multipletests(rates.loc[sel, "fisher_p"], alpha=ALPHA, method="holm")
            rates.loc[sel, "holm_p"] = adj
            rates.loc[sel, "verdict"] = np.where(reject, "differ", "not shown to differ")
        rates.loc[rates["condition"].str.startswith(label) & rates["fisher_p"].isna(), "verdict"] = "not judged"
    pd.DataFrame(coupling_rows).to_csv(out / "coupling.csv", index=False)
    rates.to_csv(out / "rates.csv", index=False, float_format="%.4g")
    pd.concat([mutants.index.to_frame(index=False), pd.DataFrame(case_cols)], axis=1).to_csv(
        out / "cases.csv", index=False, float_format="%.4g")
    print(pd.DataFrame(coupling_rows).drop(columns=["targets_missed_cases_cannot_kill"]).to_string())
    print(rates.to_string())


if __name__ == "__main__":
    main()
