"""Reads one HUPA-UCM person's raw device exports -- the Medtronic CareLink
CSV of their Paradigm Veo 754 pump and the FreeStyle Libre CSV of their
sensor, both written by the devices' Spanish-language software -- into one
per-minute record on the person's local clock (Europe/Madrid).

What is read, and how (every choice is named here, none is silent):

- glucose: the Libre's historic readings (record type 0, every 15 min);
  scans (type 1) and the pump's own sensor section are not used, so every
  person is seen through the same sensor.
- carbohydrate: the pump's bolus wizard input, logged in exchanges
  (raciones); 1 exchange = 10 g, the Spanish convention the HUPA-UCM
  authors also use. Libre food entries are counted and reported, not used.
- boluses: `Bolus Volume Delivered (U)` of Normal, Dual (normal part) rows
  at their time; Square and Dual (square part) rows spread evenly over
  their `Bolus Duration` from their time. Rows with nothing delivered are
  skipped (a programmed bolus that was cancelled).
- basal as delivered, per minute: `Basal Rate (U/h)` rows set the scheduled
  rate from then on; a temporary basal (percent or absolute) replaces it
  for its duration; nothing is delivered between a suspension
  (USER_SUSPEND, ALARM_SUSPEND, NOTSEATED_SUSPEND, LOWSG_SUSPEND and the
  LOW_SUSPEND_* states) and the next resumption (NORMAL_PUMPING,
  USER_RESTART_BASAL, AUTO_RESUME_*). The Veo's low-glucose suspend is the
  only automation; these pumps run open loop otherwise.

A row that cannot be read is an error naming the file, the line and the
field.
"""

import collections
import datetime as dt
import re

PID = re.compile(r"^HUPA\d{4}P$")
GRAMS_PER_EXCHANGE = 10.0
RESUME = {"NORMAL_PUMPING", "USER_RESTART_BASAL", "AUTO_RESUME_COMPLETE", "AUTO_RESUME_REDUCED"}


class DataError(Exception):
    pass


def split_merged(path):
    """The per-person lines of a file in which someone concatenated every
    person's raw export with pandas (the copy reachable on GitHub, see
    README): each line holds its person's id as a comma-separated cell and
    the original `;`- or tab-separated line as the other non-empty cells."""
    out = collections.defaultdict(list)
    with open(path, encoding="utf-8", errors="strict") as f:
        for n, line in enumerate(f, 1):
            cells = line.rstrip("\r\n").split(",")
            pids = [c for c in cells if PID.match(c)]
            if len(pids) != 1:
                continue  # the merge's own header lines
            out[pids[0]].append(",".join(c for c in cells if c and not PID.match(c)))
    return out


def _num(text, what, where):
    t = text.strip()
    if t == "":
        return None
    try:
        return float(t.replace(",", "."))
    except ValueError:
        raise DataError(f"{where}: {what}: not a number: {text!r}") from None


def _when(date, time, where):
    date, time = date.strip(), time.strip()
    for fmt in ("%d/%m/%Y %H:%M:%S", "%Y/%m/%d %H:%M:%S", "%d/%m/%Y %H:%M", "%Y/%m/%d %H:%M"):
        try:
            return dt.datetime.strptime(f"{date} {time}", fmt)
        except ValueError:
            pass
    raise DataError(f"{where}: Date/Time: not a date and time: {date!r} {time!r}")


def _duration_min(text, where):
    t = text.strip()
    if not t:
        return None
    parts = t.split(":")
    if len(parts) != 3 or not all(p.isdigit() for p in parts):
        raise DataError(f"{where}: duration: expected h:mm:ss, got {text!r}")
    h, m, s = map(int, parts)
    return h * 60 + m + s / 60.0


def read_pump(lines, name):
    """The pump section of a CareLink export: dict of lists of events."""
    ev = {"basal": [], "temp": [], "suspend": [], "bolus": [], "carbs": [], "ratio": []}
    header, section = None, None
    for n, line in enumerate(lines, 1):
        cells = line.split(";")
        where = f"{name} line {n}"
        if cells[0].startswith("-------"):
            section = cells[2].strip() if len(cells) > 2 else ""
            header = None
            continue
        if cells[0].startswith("Index"):
            header = cells
            continue
        if header is None or section != "Pump" or len(cells) < 3:
            continue
        row = dict(zip(header, cells))
        if not row.get("Date", "").strip() and not row.get("Time", "").strip():
            continue  # a blank separator line
        at = _when(row["Date"], row["Time"], where)
        rate = _num(row.get("Basal Rate (U/h)", ""), "Basal Rate (U/h)", where)
        if rate is not None:
            ev["basal"].append((at, rate))
        amount = _num(row.get("Temp Basal Amount", ""), "Temp Basal Amount", where)
        if amount is not None:
            kind = row.get("Temp Basal Type", "").strip()
            if kind not in ("Percent", "Absolute"):
                raise DataError(f"{where}: Temp Basal Type: expected Percent or Absolute, got {kind!r}")
            dur = _duration_min(row.get("Temp Basal Duration (h:mm:ss)", ""), where)
            if dur is None:
                raise DataError(f"{where}: Temp Basal Duration: missing")
            ev["temp"].append((at, kind, amount, dur))
        state = row.get("Suspend", "").strip()
        if state:
            if state in RESUME:
                ev["suspend"].append((at, False))
            elif "SUSPEND" in state:
                ev["suspend"].append((at, True))
            else:
                raise DataError(f"{where}: Suspend: unknown state {state!r}")
        btype = row.get("Bolus Type", "").strip()
        delivered = _num(row.get("Bolus Volume Delivered (U)", ""), "Bolus Volume Delivered (U)", where)
        if btype and delivered:
            if btype in ("Normal", "Dual (normal part)"):
                ev["bolus"].append((at, delivered, 0.0))
            elif btype in ("Square", "Dual (square part)"):
                dur = _duration_min(row.get("Bolus Duration (h:mm:ss)", ""), where)
                if not dur:
                    raise DataError(f"{where}: Bolus Duration: a square bolus needs its duration")
                ev["bolus"].append((at, delivered, dur))
            else:
                raise DataError(f"{where}: Bolus Type: unknown {btype!r}")
        ex = _num(row.get("BWZ Carb Input (exchanges)", ""), "BWZ Carb Input (exchanges)", where)
        if ex:
            ev["carbs"].append((at, ex * GRAMS_PER_EXCHANGE))
        ratio = _num(row.get("BWZ Carb Ratio (U/Ex)", ""), "BWZ Carb Ratio (U/Ex)", where)
        if ratio:
            ev["ratio"].append((at, GRAMS_PER_EXCHANGE / ratio))
    if header is None and not ev["basal"]:
        raise DataError(f"{name}: no pump section (an `Index;Date;Time;...` header after `-------;...;Pump`)")
    for k in ev:
        ev[k].sort(key=lambda e: e[0])
    return ev


def read_libre(lines, name):
    """Historic glucose readings of a FreeStyle Libre export (Spanish
    headers, `;` or tab separated): list of (local datetime, mg/dL), and
    the number of food rows (not used)."""
    sep = "\t" if "\t" in lines[0] else ";"
    header = lines[0].split(sep)
    need = ["Hora", "Tipo de registro", "Histórico glucosa (mg/dL)"]
    for k in need:
        if k not in header:
            raise DataError(f"{name} line 1: missing column {k!r}")
    out, food = [], 0
    for n, line in enumerate(lines[1:], 2):
        row = dict(zip(header, line.split(sep)))
        kind = row.get("Tipo de registro", "").strip()
        where = f"{name} line {n}"
        if kind == "5":
            food += 1
        if kind != "0":
            continue
        g = _num(row["Histórico glucosa (mg/dL)"], "Histórico glucosa (mg/dL)", where)
        if g is None:
            raise DataError(f"{where}: Histórico glucosa (mg/dL): empty on a historic row")
        date, _, time = row["Hora"].strip().partition(" ")
        out.append((_when(date, time, where), g))
    out.sort()
    dedup = []
    for at, g in out:
        if dedup and dedup[-1][0] == at:
            continue  # the same reading exported twice
        dedup.append((at, g))
    return dedup, food


class Record:
    """One person's record per local minute from 00:00 of `day0`."""

    def __init__(self, pump, libre, day0, days):
        self.day0 = day0
        self.days = days
        n = days * 1440
        t0 = dt.datetime.combine(day0, dt.time())
        minute = lambda at: int((at - t0).total_seconds() // 60)
        # Scheduled basal in force at t0: the last Basal Rate row before it.
        before = [r for at, r in pump["basal"] if at <= t0]
        if not before:
            raise DataError(f"no Basal Rate row before {t0}: the basal in force is unknown")
        sched = [before[-1]] * n
        for at, r in pump["basal"]:
            m = minute(at)
            if 0 <= m < n:
                for k in range(m, n):
                    sched[k] = r
        delivered = list(sched)
        for at, kind, amount, dur in pump["temp"]:
            m0, m1 = minute(at), minute(at + dt.timedelta(minutes=dur))
            for k in range(max(m0, 0), min(m1, n)):
                delivered[k] = sched[k] * amount / 100.0 if kind == "Percent" else amount
        suspended = False
        state = [False] * n
        events = sorted(pump["suspend"], key=lambda e: e[0])
        prior = [s for at, s in events if at < t0]
        suspended = prior[-1] if prior else False
        i = 0
        inside = [(minute(at), s) for at, s in events if at >= t0]
        for k in range(n):
            while i < len(inside) and inside[i][0] <= k:
                suspended = inside[i][1]
                i += 1
            state[k] = suspended
        self.basal_u_per_h = [0.0 if state[k] else delivered[k] for k in range(n)]
        self.scheduled_u_per_h = sched
        self.bolus_u = [0.0] * n
        for at, units, dur in pump["bolus"]:
            m = minute(at)
            if dur <= 0:
                if 0 <= m < n:
                    self.bolus_u[m] += units
            else:
                steps = max(1, int(round(dur)))
                for k in range(m, m + steps):
                    if 0 <= k < n:
                        self.bolus_u[k] += units / steps
        self.carbs_g = [0.0] * n
        for at, g in pump["carbs"]:
            m = minute(at)
            if 0 <= m < n:
                self.carbs_g[m] += g
        self.glucose = [(minute(at), g) for at, g in libre if 0 <= minute(at) < n]
        ratios = [r for at, r in pump["ratio"] if minute(at) < n]
        self.carb_ratio_g_per_u = sorted(ratios)[len(ratios) // 2] if ratios else None

    def day_readings(self, d):
        return [g for m, g in self.glucose if d * 1440 <= m < (d + 1) * 1440]


def full_days(pump, libre, min_readings=88):
    """Local days with at least `min_readings` of the Libre's 96 and inside
    the pump export's range (a day without pump data has no insulin)."""
    per_day = collections.Counter(at.date() for at, _ in libre)
    pump_times = [e[0] for k in ("basal", "bolus", "suspend") for e in pump[k]]
    if not pump_times:
        return []
    first, last = min(pump_times).date(), max(pump_times).date()
    return sorted(d for d, c in per_day.items() if c >= min_readings and first < d < last)
