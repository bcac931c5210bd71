"""Runs a written rotor with default numerics, co-simulated and as its continuous twin, and judges
the pair: both end with exit 0, no coupled step accepted unconverged, the stops' contacts start
and end at the same times in both models, and the flap (teeter, pad) histories agree.

Tolerances, from the two stop models' own differences:
- a contact's start: the twin's Hunt–Crossley law touches when the gap closes, the co-simulated
  pad when its node (on a tie of compliance c) reaches the plane; the two differ by the law's
  contact time at most (the twin's contact lasts ~contact_duration, Moreau–Jean's is instantaneous)
  plus a few steps of the tie's transient: |Δt| <= contact_duration + 5 h;
- the flap angle: the co-simulated blade is lighter by the pad's mass (carried by the tie) and
  its stops act through a compliant tie, the twin's through a compliant law, so the flap histories
  agree to a share of the motion: RMS difference <= 0.5° + 10 % of the flap angle's range (a
  hingeless pad's height: 2 mm + 10 % of its range)."""
import csv
import json
import math
import os
import subprocess
import time


def read_history(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    header = rows[0]
    cols = {h: [] for h in header}
    for row in rows[1:]:
        for h, v in zip(header, row):
            try:
                cols[h].append(float(v))
            except ValueError:
                cols[h].append(float("nan"))
    return cols


def episodes(times, values, floor):
    out, start = [], None
    for t, v in zip(times, values):
        on = abs(v) > floor
        if on and start is None:
            start = t
        if not on and start is not None:
            out.append((start, prev))
            start = None
        prev = t
    if start is not None:
        out.append((start, times[-1]))
    return out


def launch(bin_dir, scenario, out, sets=(), timeout=1800):
    cmd = [os.path.join(bin_dir, "cosim_launch"), scenario, "--out", out]
    for s in sets:
        cmd += ["--set", s]
    t0 = time.time()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        code, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired:
        code, err = -1, f"no answer in {timeout} s"
    wall = time.time() - t0
    summary = {}
    try:
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
    except (OSError, ValueError):
        pass
    return {"code": code, "wall": wall, "summary": summary, "stderr": err.strip().splitlines()[-1:] if err else []}


def contact_lists(rotor, hist, twin):
    """Per stop (blade or pad): the contact episodes in one model's history."""
    t = hist["time"]
    out = {}
    if rotor["topology"] == "teetering":
        if twin:
            f = hist.get("stop", [])
            out["pad1"] = episodes(t, [max(0.0, v) if True else v for v in f], 1e-9) if f else []
            # The teeter stop's moment: one sign per side; split them.
            out["pad1"] = episodes(t, [v if v < 0 else 0.0 for v in f], 1e-9)
            out["pad2"] = episodes(t, [v if v > 0 else 0.0 for v in f], 1e-9)
        else:
            for k in (1, 2):
                out[f"pad{k}"] = episodes(t, hist.get(f"stop{k}_mast", []), 1e-12)
        return out
    for k in range(1, rotor["blades"] + 1):
        if twin and rotor["topology"] == "articulated":
            out[f"pad{k}"] = episodes(t, hist.get(f"stop{k}", []), 1e-9)
        else:
            d, u = hist.get(f"stop{k}_droop", []), hist.get(f"stop{k}_antiflap", [])
            out[f"pad{k}"] = episodes(t, [abs(a) + abs(b) for a, b in zip(d, u)], 1e-12 if not twin else 1e-9)
    return out


def compare_contacts(a, b, tol):
    """Each episode of model a matched with model b's nearest by start and end: the worst
    mismatches [s] and the count of episodes without a partner within tol."""
    worst_start = worst_end = 0.0
    unmatched = 0
    for key in a:
        ea, eb = a[key], b.get(key, [])
        for s, e in ea:
            if not eb:
                unmatched += 1
                continue
            ds = min(abs(s - s2) for s2, _ in eb)
            de = min(abs(e - e2) for _, e2 in eb)
            worst_start, worst_end = max(worst_start, ds), max(worst_end, de)
            if ds > tol or de > tol:
                unmatched += 1
    return worst_start, worst_end, unmatched


def flap_columns(rotor):
    if rotor["topology"] == "teetering":
        return ["teeter"]
    return [f"flap{k}" for k in range(1, rotor["blades"] + 1)]


def judge(folder, bin_dir, restart=False):
    """Runs both scenes in `folder` and returns the verdict (a dict; 'ok' and 'why')."""
    with open(os.path.join(folder, "rotor.json")) as f:
        rotor = json.load(f)
    res = {"name": rotor["name"], "topology": rotor["topology"], "blade_model": rotor["blade_model"]}
    res.update({k: rotor[k] for k in ("excitation", "blades", "node_mass", "regularization", "processes", "restitution")})
    co = launch(bin_dir, os.path.join(folder, "rotor.pbtxt"), os.path.join(folder, "cosim"))
    tw = launch(bin_dir, os.path.join(folder, "rotor_continuous.pbtxt"), os.path.join(folder, "twin"))
    res["cosim_code"], res["twin_code"] = co["code"], tw["code"]
    res["cosim_wall"], res["twin_wall"] = round(co["wall"], 2), round(tw["wall"], 2)
    why = []
    for label, r in (("co-simulated", co), ("continuous", tw)):
        if r["code"] != 0:
            reason = r["summary"].get("reason") or " ".join(r["stderr"])
            why.append(f"{label} exit {r['code']}: {reason}")
    counters = co["summary"].get("counters", {})
    res["marked"] = counters.get("coupling_steps_marked", 0)
    res["retried"] = counters.get("coupling_steps_retried", 0)
    if res["marked"]:
        why.append(f"{res['marked']} coupled steps accepted unconverged")
    if co["code"] == 0 and tw["code"] == 0:
        hc = read_history(os.path.join(folder, "cosim", "history.csv"))
        ht = read_history(os.path.join(folder, "twin", "history.csv"))
        h = rotor["step"]
        tol = rotor["contact_duration"] + 5 * h
        ca, ct = contact_lists(rotor, hc, False), contact_lists(rotor, ht, True)
        res["contacts_cosim"] = sum(len(v) for v in ca.values())
        res["contacts_twin"] = sum(len(v) for v in ct.values())
        ws, we, un = compare_contacts(ca, ct, tol)
        ws2, we2, un2 = compare_contacts(ct, ca, tol)
        res["contact_start_worst"] = round(max(ws, ws2), 4)
        res["contact_end_worst"] = round(max(we, we2), 4)
        res["contacts_unmatched"] = un + un2
        if un + un2:
            why.append(
                f"{un + un2} stop contacts without a partner within {tol:.3g} s in the other model "
                f"(worst start {max(ws, ws2):.3g} s, end {max(we, we2):.3g} s)"
            )
        worst = 0.0
        for col in flap_columns(rotor):
            a, b = hc.get(col), ht.get(col)
            if not a or not b:
                continue
            n = min(len(a), len(b))
            rms = math.sqrt(sum((a[i] - b[i]) ** 2 for i in range(n)) / n)
            span = max(b[:n]) - min(b[:n])
            floor = 2e-3 if rotor["topology"] == "hingeless" else 0.5
            allowed = floor + 0.1 * span
            worst = max(worst, rms / allowed)
            res.setdefault("flap_rms", 0.0)
            res["flap_rms"] = max(res["flap_rms"], round(rms, 4))
        res["flap_rms_share"] = round(worst, 3)
        if worst > 1:
            why.append(f"flap histories differ by {res['flap_rms']} RMS ({worst:.2f} of the tolerance)")
        if restart and res["contacts_cosim"]:
            why += check_restart(folder, bin_dir, rotor, ca, hc, res)
    res["ok"] = not why
    res["why"] = "; ".join(why)
    return res


def check_restart(folder, bin_dir, rotor, contacts, hist, res):
    """Stops the co-simulated run in the middle of its first contact that lasts more than two
    steps, restarts it from the saved states and compares the rest with the run made in one go."""
    h = rotor["step"]
    mids = [s + round((e - s) / 2 / h) * h for ep in contacts.values() for s, e in ep if e - s > 2 * h]
    if not mids:
        return []
    t_mid = round(min(mids) / h) * h
    first = os.path.join(folder, "restart_a")
    a = launch(bin_dir, os.path.join(folder, "rotor.pbtxt"), first, [f"numerics.end_time={t_mid:.6g}"])
    if a["code"] != 0:
        return [f"restart: the run to {t_mid:.6g} s ended with exit {a['code']}"]
    second = os.path.join(folder, "restart_b")
    b = launch(
        bin_dir,
        os.path.join(folder, "rotor.pbtxt"),
        second,
        [
            f"numerics.start_time={t_mid:.6g}",
            f"numerics.initial_state={os.path.join(first, 'final_state.pb')}",
            "numerics.smooth.settle=false",  # (a saved state is settled already)
        ],
    )
    if b["code"] != 0:
        return [f"restart from {t_mid:.6g} s ended with exit {b['code']}: {b['summary'].get('reason', '')}"]
    hb = read_history(os.path.join(second, "history.csv"))
    index = {round(t / h): i for i, t in enumerate(hist["time"])}
    worst = 0.0
    for col in flap_columns(rotor):
        for t, v in zip(hb["time"], hb.get(col, [])):
            i = index.get(round(t / h))
            if i is not None:
                worst = max(worst, abs(v - hist[col][i]))
    res["restart_time"] = t_mid
    res["restart_difference"] = worst
    return [f"restart at {t_mid:.6g} s departs from the run made in one go by {worst:.3g}"] if worst > 1e-6 else []
