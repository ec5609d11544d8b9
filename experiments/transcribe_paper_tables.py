"""Transcribe the paper's tables from its extracted text (../shared/paper/) into
experiments/paper_tables.json, with the typo readings listed under "notes". Run once; the JSON is
committed (the paper is not part of the package)."""

import json
import re
from pathlib import Path

HERE = Path(__file__).resolve().parent
L = (HERE.parents[1] / "shared" / "paper" / "jesenik2020-mathematics-8-1269.txt").read_text().splitlines()
NUM = re.compile(r"^-?[\d.]+(?:\s*[×x]\s*10\^\{(-?\d+)\})?$")


def num(cell):
    cell = cell.strip().replace("$", "")
    if cell in ("0.0", "0"):
        return 0.0
    m = re.match(r"^(-?[\d.]+)\s*(?:×\s*10\^\{(-?\d+)\})?$", cell)
    if not m:
        return None
    v = float(m.group(1))
    if m.group(2):
        v *= 10.0 ** int(m.group(2))
    return v


PARAMS = ["Ra", "La", "cm", "J", "Tla", "Tlb", "Tlc"]


def of_param_block(start, ncols, skip_known):
    """Rows B, W, M, SD then 7 parameter rows, starting at the first 'B' row after `start`."""
    rows = []
    i = start
    while len(rows) < 11:
        parts = L[i].split("\t")
        cells = [p for p in parts if p.strip() != ""]
        vals = [num(c) for c in cells]
        nums = [v for v in vals if v is not None]
        if len(nums) >= ncols:
            rows.append(nums[-ncols:])
        i += 1
    labels = ["OF_B", "OF_W", "OF_M", "OF_SD"] + PARAMS
    return dict(zip(labels, rows))


out = {"source": "Jesenik et al., Mathematics 2020, 8, 1269 (../shared/paper/); transcribed from the extracted text", "notes": {}}
methods = ["ga", "de-rand-1-exp", "de-best-1-bin", "tlbo", "abc"]
for tab, line in [(9, 398), (10, 414), (11, 443), (12, 459), (13, 488), (14, 506), (15, 539), (16, 555)]:
    out[f"table{tab}"] = {"columns": methods, **of_param_block(line, 5, True)}
variants = ["EM", "EM5", "EM10", "RK", "RK5", "RK10"]
for tab, line in [(24, 851), (25, 888), (26, 918), (27, 947)]:
    out[f"table{tab}"] = {"columns": variants, **of_param_block(line, 6, False)}
for tab, line in [(20, 750), (21, 767), (22, 782), (23, 797)]:
    rows = {}
    cand = [l for l in L[line : line + 30] if re.match(r"^0\.\d, 0\.\d", l)][:9]
    for l in cand:
        parts = [p for p in l.split("\t") if p.strip()]
        w1 = float(parts[0].split(",")[0])
        rows[f"{w1:.1f}"] = [num(c) for c in parts[1:9]]
    out[f"table{tab}"] = {"columns": PARAMS + ["OF"], "rows": rows}
# Table 19 and 28: times (s)
t19 = {}
t19_lines = [l for l in L[714:740] if re.match(r"^MD\d", l)][:8]
for k in range(8):
    parts = [p for p in t19_lines[k].split("\t") if p.strip()]
    t19[["MD1/EM", "MD1/RK", "MD2/EM", "MD2/RK", "MD3/EM", "MD3/RK", "MD4/EM", "MD4/RK"][k]] = [float(x) for x in parts[-5:]]
out["table19"] = {"columns": methods, "rows": t19}
t28 = {}
t28_lines = [l for l in L[977:995] if re.match(r"^MD\d", l)][:4]
for k in range(4):
    parts = [p for p in t28_lines[k].split("\t") if p.strip()]
    t28[f"MD{k + 1}"] = [float(x) for x in parts[-6:]]
t28["MD4"][2] = 50.2
out["notes"]["table28"] = "MD4 EM10 prints as 502 in the extracted text; 50.2 s used (between EM5 42.4 and RK10 91.0)."
out["table28"] = {"columns": variants, "rows": t28}
# Tables 30-33: Time %, Dupl % per variant for STMA, LTMA-S1, LTMA-S2
mem = {}
for tab, md, lines in [
    (30, "MD1", (1037, 1038, 1039)),
    (31, "MD2", (1046, 1047, 1048)),
    (32, "MD3", (1055, 1056, None)),
    (33, "MD4", (1081, 1082, 1083)),
]:
    rows = {}
    for name, ln in zip(["stma", "ltma-s1", "ltma-s2"], lines):
        if ln is None:
            continue
        parts = [p for p in L[ln - 1].split("\t") if p.strip()][1:]
        v = [float(x) for x in parts]
        rows[name] = {"time_pct": v[0::2], "dupl_pct": v[1::2]}
    out[f"table{tab}"] = {"data": md, "columns": variants, "rows": rows}
# Table 32 LTMA-S2 row is scattered in the extracted text (lines 1076-1091): Time/Dupl pairs
out["table32"]["rows"]["ltma-s2"] = {"time_pct": [162.8, 159.2, 138.1, 134.4, 78.6, 64.3], "dupl_pct": [83.7, 77.9, 85.2, 84.9, 85.0, 84.9]}
out["notes"]["table32"] = (
    "The LTMA-S2 row of Table 32 is split across the extracted text; the pairs are read as "
    "EM 162.8/83.7, EM5 159.2/77.9, EM10 138.1/85.2, RK 134.4/84.9, RK5 78.6/85.0, RK10 64.3/84.9 "
    "(ordering inferred; the text says RK10 LTMA-S2 times were 56.8-64.3 % for MD1-MD3)."
)
# Table 5 and 6
out["table5"] = {
    "columns": ["B", "W", "M", "SD"],
    "rows": {
        "SD1": {
            "ga": (3.2054e-4, 4.3669e-1, 1.0765e-1, 1.1031e-1),
            "de-rand-1-exp": (4.8980e-19, 4.8980e-19, 4.8980e-19, 2.0882e-27),
            "de-best-1-bin": (4.8980e-19, 2.5072e-2, 6.6203e-4, 3.6637e-3),
            "tlbo": (3.9564e-15, 2.7757e-10, 1.6827e-11, 4.7340e-11),
            "abc": (6.8520e-10, 1.6968e-7, 3.4562e-8, 4.3330e-8),
        },
        "SD2": {
            "ga": (7.8123e-5, 1.8151e-1, 5.2484e-2, 5.0508e-2),
            "de-rand-1-exp": (6.2556e-19, 6.2556e-19, 6.2556e-19, 3.5547e-27),
            "de-best-1-bin": (6.2556e-19, 4.6771e-2, 9.3542e-4, 6.5479e-3),
            "tlbo": (7.8460e-13, 7.3488e-9, 5.1639e-10, 1.0976e-9),
            "abc": (1.0932e-9, 2.1087e-7, 4.1001e-8, 4.5495e-8),
        },
        "SD3": {
            "ga": (6.9449e-5, 2.8716e-1, 7.4399e-2, 6.716e-2),
            "de-rand-1-exp": (4.6666e-19, 4.6666e-19, 4.6666e-19, 2.2635e-27),
            "de-best-1-bin": (4.6666e-19, 4.6005e-2, 2.3516e-3, 9.1419e-3),
            "tlbo": (1.9151e-12, 2.6491e-9, 3.3533e-10, 5.0565e-10),
            "abc": (6.1774e-11, 2.1340e-9, 5.2114e-10, 4.4003e-10),
        },
        "SD4": {
            "ga": (3.6061e-3, 2.8045e-1, 1.3085e-1, 8.1103e-2),
            "de-rand-1-exp": (3.0248e-19, 3.0248e-19, 3.0248e-19, 1.1859e-27),
            "de-best-1-bin": (3.0248e-19, 8.7846e-2, 4.4826e-3, 1.3509e-2),
            "tlbo": (4.523e-16, 4.2365e-9, 1.5931e-10, 6.8381e-10),
            "abc": (9.7925e-9, 4.1963e-7, 1.3155e-7, 9.5220e-8),
        },
    },
}
out["table6"] = {
    "columns": methods,
    "rows": {
        "Ra": [37.34, 42.5, 43.58, 42.5, 42.48],
        "La": [5.692e-2, 8e-2, 8.116e-2, 8e-2, 8.002e-2],
        "cm": [0.6782, 0.4781, 0.4773, 0.4781, 0.4781],
        "J": [8.302e-5, 2e-5, 1.978e-5, 2e-5, 2.004e-5],
        "Tla": [1.358e-2, 1e-2, 0.981e-2, 0.998e-2, 0.736e-2],
        "Tlb": [2.033e-5, 3.270e-5, 3.026e-5, 3.260e-5, 2.577e-5],
        "Tlc": [4.778e-8, 8.55e-8, 10.98e-8, 8.850e-8, 11.34e-8],
    },
}
out["table18"] = {
    "max_u_dev_pct": {"MD1": 1.9, "MD2": 2.7, "MD3": 1.1, "MD4": 1.1},
    "max_i_dev_pct": {"MD1": 8.1, "MD2": 13.0, "MD3": 13.1, "MD4": 1.9},
}
# Table 7: the conditions of MD1–MD4 (the measurement step, 0.132 s, is in the text below it).
t7 = L.index(next(x for x in L if x.startswith("Table 7.")))
rows7 = {r.split("\t")[0].split(" ")[0]: [c for c in r.split("\t")[1:] if c.strip()] for r in L[t7 - 6 : t7 - 1]}
out["table7"] = {
    "columns": ["MD1", "MD2", "MD3", "MD4"],
    "t_speed_up": [float(c) for c in rows7["t"]],
    "omega_final": [float(c) for c in rows7["ω_{final}"]],
    "i_a_limit": [float(c.split(" ")[0]) for c in rows7["i"]],
    "points": [int(c) for c in rows7["Number"]],
    "dt_sample": float(re.search(r"time step was ([\d.]+) s", L[t7 + 2]).group(1)),
}
# Fig. 12 (Section 4.2.6): the text gives the MD1 row, own fit then R_MD2 and R_MD3.
sec = "\n".join(L[L.index(next(x for x in L if x.startswith("4.2.6."))) :][:20])
fig12 = [float(a) * 1e-3 for a in re.findall(r"OF = ([\d.]+)\s*×\s*10(?:\^\{-3\}|⁻³)", sec)]
out["fig12"] = {"data": "MD1", "columns": ["R_MD1", "R_MD2", "R_MD3"], "OF": fig12}
out["known"] = {"Ra": 5.66, "J": 0.04, "Tla": 0.9, "Tlb_MD4": 0.075}
out["notes"]["table10"] = "DE/best/1/bin OF SD prints as 28456e-4 (a lost decimal point); 2.8456e-4 used."
out["table10"]["OF_SD"][2] = 2.8456e-4
for t in (24, 25, 26, 27):
    tab = out[f"table{t}"]
    for row in ("OF_B", "OF_W", "OF_M", "OF_SD"):
        tab[row] = [v * 1e-2 if v > 0.1 else v for v in tab[row]]
    tab["J"] = [v * 1e-1 if v > 0.3 else v for v in tab["J"]]
out["notes"]["tables24-27"] = (
    "Several OF cells print as x10^-1 beside x10^-3 neighbours (e.g. Table 24 RK5 2.1453e-1, "
    "identical runs with SD ~1e-18) and several J cells as 4.4e-1 beside 4.4e-2: exponent typos, "
    "read as 10^-3 and 10^-2. Table 25 RK5 SD prints equal to its mean (2.3706e-1): left as printed / 100."
)
json.dump(out, open(HERE / "paper_tables.json", "w"), indent=1)
