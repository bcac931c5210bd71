"""Runs a written rotor with default numerics, co-simulated and as its continuous twin, and judges
the pair: both end with exit 0, no coupled step accepted unconverged, the stops' contacts start
and end at the same times in both models, and the flap (teeter, pad) histories agree.

The two models differ where the stops act: the co-simulated pad meets its plane in a Newton
impact (instantaneous, restitution e) through a tie of compliance c; the twin's Hunt–Crossley law
is a compliant contact lasting about T_c = contact_duration (20 ms on a flap or teeter hinge, 5 ms
on a hingeless pad: spec.twin_contact_duration) with the same effective e.
Hence the tolerances:
- contacts: every contact of one model has the other in contact within tol = T_c + 5 h of its
  start and end (the law's duration, a few steps of the tie's transient), plus T_c for each impact
  of that pad before it (each contact the law resolves over T_c shifts the flight after it by up
  to T_c: bounce series drift apart), unless the other model's blade is on its stop then anyway
  (pressed into it, or within the larger of 5 % of the stops' span and the difference the flap
  histories may have, below: a load in balance, a bounce series the law merges, a graze);
- flap histories before the first impact of any blade (lift-offs, free flight, the gust or the
  run-up): RMS difference <= 0.1° + 2 % of the range (a hingeless pad's height: 0.5 mm + 2 %):
  the models differ there only by where the pad's mass sits and the stops' static compliance;
- the extremes of each blade's flap over the whole run (what a blade-sailing study reports: the
  highest and the lowest tip): within 0.5° + 10 % of the range (2 mm + 10 %);
- each co-simulated impact of a rigid blade (or yoke) on its hinge's stop rebounds at Newton's e:
  the hinge rate after it at most 1.1 e + 0.01 times the rate before it (rebounds).
A pair whose contacts or flaps disagree is judged again against refined twins, their stop
contacts 2, 4, 8 and 16 times shorter at steps as many times smaller, each with its own T_c in
the tolerances above (tighter), and passes if one agrees (res["twin_refinement"]). Newton's stop
is the limit of the twin's as T_c goes to 0, and where a 20 ms law changes what follows (a slow
yoke's swing after its impact, a bounce series) the refined twins converge to the co-simulated
run; a co-simulation that is wrong disagrees with all of them (the code before the impacting-node
restart on rotors 639, 651, 784, 795 and 805: every one still fails against the twin refined 16
times).
"""
import csv
import json
import math
import os
import subprocess
import time

from rotors import scene, spec

# The judge's refined twins, tried in turn on a pair that disagrees: the twin's stop contacts
# this many times shorter, at a step as many times smaller (scene.write_refined_twin).
REFINEMENTS = (2, 4, 8, 16)


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
    out, start, prev = [], None, None
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
            f, teeter = hist.get("stop", []), hist.get("teeter", [])
            # The teeter stop's law force (a magnitude): at the lower stop (teeter < 0) pad 1, on
            # the +x side of the yoke, meets its mast plane as blade 1 goes down; at the upper, pad 2.
            out["pad1"] = episodes(t, [v if b < 0 else 0.0 for v, b in zip(f, teeter)], 1e-9)
            out["pad2"] = episodes(t, [v if b > 0 else 0.0 for v, b in zip(f, teeter)], 1e-9)
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


def stop_positions(rotor):
    """Per pad: (its flap column, the stop positions it meets in that column's units)."""
    deg = 180 / math.pi
    if rotor["topology"] == "teetering":
        return {"pad1": ("teeter", [rotor["droop"] * deg]), "pad2": ("teeter", [rotor["antiflap"] * deg])}
    if rotor["topology"] == "articulated":
        return {
            f"pad{k}": (f"flap{k}", [rotor["droop"] * deg, rotor["antiflap"] * deg])
            for k in range(1, rotor["blades"] + 1)
        }
    gap = scene.Writer(spec.Rotor(**rotor)).hingeless_gap()
    return {f"pad{k}": (f"flap{k}", [0.0, gap]) for k in range(1, rotor["blades"] + 1)}


def in_contact(times, eps):
    flags = [False] * len(times)
    j = 0
    for i, t in enumerate(times):
        while j < len(eps) and eps[j][1] < t - 1e-12:
            j += 1
        flags[i] = j < len(eps) and eps[j][0] - 1e-12 <= t
    return flags


def compare_contacts(rotor, ha, ea, hb, eb, tol):
    """Times at which model a has a pad in contact while model b has it clearly off its stops
    with no contact within ±tol: a contact one model has and the other has not, or one that starts
    or ends more than tol apart. A pad that the other model holds on its stop without a recorded
    contact (a bounce series, a load in balance) is no mismatch. Returns [(pad, first time, last
    time)] of such intervals.
    Clearly off: farther from each stop than a band, the larger of 5 % of the stops' span and the
    difference the flap histories may have (0.1° or 0.5 mm + 2 % of the range: compare_flaps; a
    graze the other model misses by less is within what the two models may differ by), measured
    from the plane and from where b's pad rests on it at the start (a twin's pad sits in its
    Hertzian stop), and not pressed into the plane. A twin pad that unloads leaves the law's force
    at 0 while still inside the plane (Hunt–Crossley's damping clipped): rotors 608 and 650 had
    their co-simulated pads lift off within a step of their twins', 0.01 mm apart, and were
    counted "in the co-simulated model only" for the 30 ms the twin spent inside its plane without
    force."""
    stops = stop_positions(rotor)
    times = ha["time"]
    n = min(len(times), len(hb["time"]))
    step = rotor["step"]
    out = []
    for key, eps in ea.items():
        # Impacts on this pad's hinge so far (contacts closing after the start), in either model:
        # every pad on the same flap column, as a blade's droop and anti-flap contacts are one
        # pad's. A teetering yoke's two pads share its one hinge, and a contact of either shifts
        # the yoke's flight after it (rotor 784: the restart gives pad 2's impact at 1.254 s
        # Newton's e = 0.391 exactly, while the twin stays 23 ms on its stop, 0.27° into it; pad 1
        # then closes 79 ms after its twin, with two closings of its own counted and pad 2's not).
        same_hinge = [k for k in ea if stops[k][0] == stops[key][0]]
        closings = sorted(s for k in same_hinge for s, _ in ea.get(k, []) + eb.get(k, []) if s > times[0] + 0.5 * step)
        drift = [0] * n
        j = 0
        for i in range(n):
            while j < len(closings) and closings[j] < times[i] - tol:
                j += 1
            drift[i] = j
        reach_at = [int(round((tol + drift[i] * rotor["contact_duration"]) / step)) for i in range(n)]
        col, where = stops[key]
        span = max(where) - min(where) if len(where) > 1 else 2 * abs(where[0])
        base = hb[col][0] if rotor["topology"] == "hingeless" else 0.0
        n_b = min(n, len(hb[col]))
        history_range = max(hb[col][:n_b]) - min(hb[col][:n_b]) if n_b else 0.0
        band = max(0.05 * span, (5e-4 if rotor["topology"] == "hingeless" else 0.1) + 0.02 * history_range)
        # The side of each stop past which b's pad is pressed into it (a lower stop: below it).
        lower = [w < max(where) or (len(where) == 1 and w < 0) for w in where]
        a_on = in_contact(times[:n], eps)
        b_on = in_contact(times[:n], eb.get(key, []))
        # b in contact anywhere within ±reach samples: a running window.
        near = [False] * n
        last = -(10**9)
        for i in range(n):
            if b_on[i]:
                last = i
            near[i] = i - last <= reach_at[i]
        nxt = 10**9
        for i in range(n - 1, -1, -1):
            if b_on[i]:
                nxt = i
            near[i] = near[i] or nxt - i <= reach_at[i]
        bad = None
        for i in range(n):
            y = hb[col][i]
            pressed = any((y < w) if low else (y > w) for w, low in zip(where, lower))
            off = not pressed and min(min(abs(y - base - w), abs(y - w)) for w in where) > band
            if a_on[i] and not near[i] and off:
                bad = (bad[0], times[i]) if bad and bad[1] >= times[i] - 1.5 * step else bad
                if bad is None or bad[1] < times[i] - 1.5 * step:
                    if bad:
                        out.append((key, *bad))
                    bad = (times[i], times[i])
        if bad:
            out.append((key, *bad))
    return out


def rate_at(times, values, x):
    """The rate at x of the parabola through three (time, value) samples."""
    (x0, x1, x2), (y0, y1, y2) = times, values
    return (
        y0 * ((x - x1) + (x - x2)) / ((x0 - x1) * (x0 - x2))
        + y1 * ((x - x0) + (x - x2)) / ((x1 - x0) * (x1 - x2))
        + y2 * ((x - x0) + (x - x1)) / ((x2 - x0) * (x2 - x1))
    )


def curvature(times, values):
    (x0, x1, x2), (y0, y1, y2) = times, values
    return 2 * (y0 / ((x0 - x1) * (x0 - x2)) + y1 / ((x1 - x0) * (x1 - x2)) + y2 / ((x2 - x0) * (x2 - x1)))


def rebounds(rotor, hist, eps):
    """Each co-simulated impact of a rigid hinge on its stop (a contact of at most three steps):
    [(pad, time, rate before [°/s], rebound)]: minus the hinge's rate after the impact over its rate
    before, each from the parabola through the three samples on its side, both taken at the
    contact's middle (the flap's smooth acceleration, the same on both sides, cancels). Newton's
    law with a rigid blade gives e; a regularised tie's transient and the parabola's error add a
    few per cent (the 103 rigid rotors of seeds 600–909: at most 1.23 e, 654 at e = 0.071, where
    the bound is 1.24 e). Left out: beam blades
    (the hinge's rebound is the blade's, bent), hingeless rotors, approaches slower than 5 °/s
    (grazes: there the tie's own transient, ~1 °/s, is the rebound) and impacts whose approach the
    flap's own acceleration changes by more than 5 % in a step (a parabola over three steps does
    not resolve it)."""
    if rotor["topology"] == "hingeless" or rotor.get("blade_model") != "rigid":
        return []
    stops = stop_positions(rotor)
    times = hist["time"]
    out = []
    for key, contacts in eps.items():
        angle = hist[stops[key][0]]
        i = 0
        for start, end in contacts:
            while i < len(times) and times[i] < start - 1e-9:
                i += 1
            j = i
            while j < len(times) and times[j] < end - 1e-9:
                j += 1
            if i < 4 or j + 4 > len(times) or j - i > 2:
                continue
            mid = 0.5 * (times[i - 1] + times[j + 1])
            before_t, before = times[i - 3 : i], angle[i - 3 : i]
            after_t, after = times[j + 1 : j + 4], angle[j + 1 : j + 4]
            rate = rate_at(before_t, before, mid)
            step = times[i] - times[i - 1]
            acceleration = max(abs(curvature(before_t, before)), abs(curvature(after_t, after)))
            if abs(rate) < 5.0 or acceleration * step > 0.05 * abs(rate):
                continue
            out.append((key, start, rate, -rate_at(after_t, after, mid) / rate))
    return out


def flap_columns(rotor):
    if rotor["topology"] == "teetering":
        return ["teeter"]
    return [f"flap{k}" for k in range(1, rotor["blades"] + 1)]


def judge(folder, bin_dir, restart=False):
    """Runs both scenes in `folder` and returns the verdict (a dict; 'ok' and 'why')."""
    with open(os.path.join(folder, "rotor.json")) as f:
        rotor = json.load(f)
    res = {"name": rotor["name"], "topology": rotor["topology"], "blade_model": rotor["blade_model"]}
    res.update(
        {k: rotor[k] for k in ("excitation", "blades", "node_mass", "regularization", "processes", "restitution")}
    )
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
        hc = read_history(os.path.join(folder, "cosim", "history_joined.csv"))
        ht = read_history(os.path.join(folder, "twin", "history.csv"))
        ca = contact_lists(rotor, hc, False)
        twin_why = compare_twin(rotor, hc, ca, ht, res)
        # A pair that disagrees is judged again against refined twins (REFINEMENTS): the
        # co-simulated stop is Newton's, instantaneous, and a twin whose contacts are shorter is
        # a closer model of it, judged with that twin's own (tighter) tolerances. Rotors 758, 825,
        # 868 and 906 disagreed with their 20 ms (hingeless: 5 ms) twins, and as the twin's
        # contact time went to 0 the twin converged to the co-simulated run: on 906 the largest
        # flap difference over 1.5-2 s was 2.93, 1.38, 0.62, 0.27 and 0.17 deg at 20, 10, 5, 2.5
        # and 1.25 ms (twin steps 0.1 ms); on 868 the yoke's lowest angle after its one impact was
        # -6.73, -6.65, -6.35 and -6.21 deg against the co-simulated -6.14 (-6.09 at h/4).
        refinement = 1
        for finer in REFINEMENTS:
            if not twin_why:
                break
            refinement = finer
            out = os.path.join(folder, f"twin_refined_{finer}")
            path = scene.write_refined_twin(spec.Rotor(**rotor), os.path.join(out, "scene"), finer)
            r = launch(bin_dir, path, out)
            res["twin_wall"] = round(res["twin_wall"] + r["wall"], 2)
            if r["code"] != 0:
                twin_why.append(f"the twin refined {finer} times ended with exit {r['code']}")
                break
            ht = read_history(os.path.join(out, "history.csv"))
            finer_rotor = dict(rotor, contact_duration=rotor["contact_duration"] / finer)
            twin_why = compare_twin(finer_rotor, hc, ca, ht, res)
        res["twin_refinement"] = refinement
        if twin_why and refinement > 1:
            twin_why[0] = f"against the twin refined {refinement} times: " + twin_why[0]
        why += twin_why
        e = rotor["restitution"]
        fast = [r for r in rebounds(rotor, hc, ca) if r[3] > 1.1 * e + 0.01]
        res["rebounds_over_e"] = len(fast)
        if fast:
            key, start, rate, ratio = max(fast, key=lambda r: r[3])
            why.append(
                f"{len(fast)} impacts rebound faster than Newton's e = {e:.3g} allows (worst: {key} at "
                f"{start:.3f} s, {ratio:.3f} times its approach at {abs(rate):.3g} °/s)"
            )
        if restart and res["contacts_cosim"]:
            why += check_restart(folder, bin_dir, rotor, ca, hc, res)
    res["ok"] = not why
    res["why"] = "; ".join(why)
    return res


def compare_twin(rotor, hc, ca, ht, res):
    """The co-simulated history `hc` (its contacts `ca`) against the twin's `ht` (on the same
    steps): contacts and flaps, with tolerances from rotor["contact_duration"], the twin's law.
    Returns the reasons."""
    h = rotor["step"]
    tol = rotor["contact_duration"] + 5 * h
    ct = contact_lists(rotor, ht, True)
    res["contacts_cosim"] = sum(len(v) for v in ca.values())
    res["contacts_twin"] = sum(len(v) for v in ct.values())
    un = compare_contacts(rotor, hc, ca, ht, ct, tol)
    un2 = compare_contacts(rotor, ht, ct, hc, ca, tol)
    res["contacts_unmatched"] = len(un) + len(un2)
    why = []
    if un or un2:
        key, a, b = (un or un2)[0]
        why.append(
            f"{len(un) + len(un2)} stop contacts without a partner within {tol:.3g} s in the other model "
            f"(first: {key} {a:.3f}-{b:.3f} s in the {'co-simulated' if un else 'continuous'} model only)"
        )
    return why + compare_flaps(rotor, hc, ht, ca, ct, res)


def compare_flaps(rotor, hc, ht, ca, ct, res):
    """The flap histories before the first impact (RMS) and their extremes over the run."""
    times = hc["time"]
    step = rotor["step"]
    closings = [s for eps in list(ca.values()) + list(ct.values()) for s, _ in eps if s > times[0] + 0.5 * step]
    first = min(closings) if closings else times[-1] + step
    hingeless = rotor["topology"] == "hingeless"
    why = []
    worst_rms = worst_peak = 0.0
    for col in flap_columns(rotor):
        a, b = hc.get(col), ht.get(col)
        if not a or not b:
            continue
        n = min(len(a), len(b))
        span = max(b[:n]) - min(b[:n])
        before = [i for i in range(n) if times[i] < first]
        if before:
            rms = math.sqrt(sum((a[i] - b[i]) ** 2 for i in before) / len(before))
            worst_rms = max(worst_rms, rms / ((5e-4 if hingeless else 0.1) + 0.02 * span))
            res["flap_rms_before_impact"] = max(res.get("flap_rms_before_impact", 0.0), rms)
        allowed = (2e-3 if hingeless else 0.5) + 0.1 * span
        peak = max(abs(max(a[:n]) - max(b[:n])), abs(min(a[:n]) - min(b[:n])))
        worst_peak = max(worst_peak, peak / allowed)
        res["flap_peak_difference"] = max(res.get("flap_peak_difference", 0.0), peak)
    res["first_impact"] = round(first, 4)
    res["flap_rms_share"], res["flap_peak_share"] = round(worst_rms, 3), round(worst_peak, 3)
    unit = "m" if hingeless else "deg"
    if worst_rms > 1:
        why.append(
            f"flap histories before the first impact ({first:.3f} s) differ by "
            f"{res['flap_rms_before_impact']:.3g} {unit} RMS ({worst_rms:.2f} of the tolerance)"
        )
    if worst_peak > 1:
        why.append(
            f"flap extremes differ by {res['flap_peak_difference']:.3g} {unit} ({worst_peak:.2f} of the tolerance)"
        )
    return why


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
    hb = read_history(os.path.join(second, "history_joined.csv"))
    index = {round(t / h): i for i, t in enumerate(hist["time"])}
    worst = 0.0
    for col in flap_columns(rotor):
        for t, v in zip(hb["time"], hb.get(col, [])):
            i = index.get(round(t / h))
            if i is not None:
                worst = max(worst, abs(v - hist[col][i]))
    res["restart_time"] = t_mid
    res["restart_difference"] = worst
    # The restarted run repeats the run made in one go to the coupling's own tolerance
    # (reaction_tolerance, 1e-6 relative): its first step's impulse within ~1e-7 relative, a
    # difference that free flight then carries on linearly. Held to 1e-5 of the flap's range.
    span = max(max(hist[c]) - min(hist[c]) for c in flap_columns(rotor))
    allowed = 1e-5 * span
    res["restart_allowed"] = allowed
    return [f"restart at {t_mid:.6g} s departs from the run made in one go by {worst:.3g}"] if worst > allowed else []
