"""Checks circfric's outputs period by period on halsampler's rows of the fric-reversal test:
   vel-cmd enable offset0 active0 direction0 reversals0 offset1 reversals1 rejected1 pos-in0
   pos-out0 offset2
(instance 0: amplitude 0.5, bound 0.6, decay 20 ms, enable switched; instance 1: amplitude
0.5, bound 0.2, decay 50 ms, always on; instance 2: amplitude 0.3, decay 40 ms, rise 10 ms,
always on; all vel-threshold 0.01, min-travel 0.001; 1 ms)."""
import math
import sys

PERIOD_S = 0.001
THRESHOLD = 0.01
MIN_TRAVEL = 0.001
TOL = 2e-6  # halsampler prints 6 decimals

rows = []
for line in open(sys.argv[1]):
    if line.strip() == "overrun":
        print("halsampler reported an overrun")
        continue
    f = line.split()
    rows.append((float(f[0]), int(f[1]), float(f[2]), int(f[3]), int(f[4]), int(f[5]),
                 float(f[6]), int(f[7]), int(f[8]), float(f[9]), float(f[10]), float(f[11])))
n = len(rows)
vel = [r[0] for r in rows]
en = [r[1] for r in rows]
off0 = [r[2] for r in rows]
act0 = [r[3] for r in rows]
dir0 = [r[4] for r in rows]
rev0 = [r[5] for r in rows]
off1 = [r[6] for r in rows]
rev1 = [r[7] for r in rows]
rej1 = [r[8] for r in rows]
pos_in = [r[9] for r in rows]
pos_out = [r[10] for r in rows]
off2 = [r[11] for r in rows]


def yes(ok):
    return "yes" if ok else "NO"


print(f"more than 3000 periods sampled: {yes(n > 3000)}")


def reversal_rows(counts):
    return [i for i in range(1, n) if counts[i] != counts[i - 1]]


# An independent Schmitt trigger with the stroke guard, run on the sampled velocity from the
# direction the module had at the first row. The stroke before the first sampled row is not
# seen: where the first change of direction comes after less than min-travel of sampled
# stroke (sampling began in the last ~30 ms before it), the module counts it or not by the
# stroke it saw before, and that row is left out of the comparison.
direction, stroke, expected, unseen = dir0[0], 0.0, [], set()
for i in range(1, n):
    now = direction
    if vel[i] > THRESHOLD:
        now = 1
    elif vel[i] < -THRESHOLD:
        now = -1
    if now != direction:
        if direction != 0 and direction * stroke >= MIN_TRAVEL:
            expected.append(i)
        elif direction != 0 and not expected and not unseen:
            unseen.add(i)
        direction, stroke = now, 0.0
    stroke += vel[i] * PERIOD_S
got = [i for i in reversal_rows(rev0) if i not in unseen]
print(f"reversals where a Schmitt trigger on the sampled vel-cmd puts them: {yes(got == expected)}")
print(f"at least 5 reversals in 3.6 s or more of a 1 Hz sine: {yes(len(got) >= 5)}")
print(f"each counted once (count steps by 1): {yes(all(rev0[i] - rev0[i - 1] == 1 for i in got))}")
print(f"direction is the sign of vel-cmd at each reversal: "
      f"{yes(all(dir0[i] == (1 if vel[i] > 0 else -1) for i in got))}")

# Pulses of instance 0 while enabled (enable seen in this row and the one before, so the
# module surely read it true in this period).
enabled = [i for i in got if en[i] and en[i - 1]]
shape_ok, at_decay = True, None
for k, i in enumerate(got):
    if i not in enabled:
        continue
    end = got[k + 1] if k + 1 < len(got) else n
    d = dir0[i]
    for j in range(i, min(end, i + 400)):
        if not en[j]:
            break
        want = d * 0.5 * math.exp(-(j - i) * PERIOD_S / 0.020)
        if abs(off0[j] - want) > TOL or act0[j] != 1:
            shape_ok = False
            print(f"  row {j}: offset {off0[j]}, want {want:.6f}, active {act0[j]}")
        if j - i == 20 and at_decay is None:
            at_decay = abs(off0[j])
print(f"pulses while enabled: at least 3: {yes(len(enabled) >= 3)}")
print(f"pulse = 0.5 exp(-t / 20 ms) in the new direction from each reversal: {yes(shape_ok)}")
print(f"|offset| 20 periods after a reversal: {at_decay:.6f} (0.5/e = {0.5 / math.e:.6f})")
print(f"offset exactly 0 after 20 time constants: "
      f"{yes(all(off0[i + 400] == 0.0 and act0[i + 400] == 0 for i in enabled if i + 400 < n and en[i + 400] and (got + [n])[got.index(i) + 1] > i + 400))}")

fell = [i for i in range(1, n) if en[i - 1] and not en[i]]
off_after = [i + 1 for i in range(n - 1) if not en[i]]
print(f"enable fell once: {yes(len(fell) == 1)}")
print(f"offset 0 and not active from the period after enable fell: "
      f"{yes(all(off0[i] == 0.0 and act0[i] == 0 for i in off_after))}")
print(f"reversals counted while disabled: {yes(any(not en[i] for i in got))}")
print(f"a pulse was running when enable fell: {yes(any(off0[i - 1] != 0.0 for i in fell))}")

# Instance 1: same detection, amplitude 0.5 bounded by amplitude-max 0.2, decay 50 ms.
got1 = [i for i in reversal_rows(rev1) if i not in unseen]
print(f"instance 1 reverses in the same periods: {yes(got1 == got)}")
print(f"instance 1 |offset| never above amplitude-max 0.2: {yes(max(abs(v) for v in off1) <= 0.2)}")
bound_ok = True
for k, i in enumerate(got1):
    end = got1[k + 1] if k + 1 < len(got1) else n
    d = 1 if off1[i] > 0 else -1
    for j in range(i, min(end, i + 1000)):
        want = d * 0.2 * math.exp(-(j - i) * PERIOD_S / 0.050)
        if abs(off1[j] - want) > TOL:
            bound_ok = False
            print(f"  instance 1 row {j}: offset {off1[j]}, want {want:.6f}")
print(f"instance 1 = 0.2 exp(-t / 50 ms): the pulse starts at amplitude-max: {yes(bound_ok)}")
print(f"instance 1 rejected nothing: {yes(all(r == 0 for r in rej1))}")
print(f"pos-out = pos-in + offset in every period: "
      f"{yes(all(abs(pos_out[i] - pos_in[i] - off0[i]) <= TOL for i in range(n)))}")
print(f"pos-out = pos-in exactly while no pulse runs: "
      f"{yes(all(pos_out[i] == pos_in[i] for i in range(n) if not act0[i]))}")

# Instance 2: 0.3 (exp(-t / 40 ms) - exp(-t / 10 ms)) / peak, the peak (0.3) at
# ln(4) 40 * 10 / 30 ms = 18.48 ms: 0 in the reversal's period, then up and down.
TD, TR = 0.040, 0.010
TP = math.log(TD / TR) * TD * TR / (TD - TR)
PEAK = math.exp(-TP / TD) - math.exp(-TP / TR)
rise_ok, highest = True, 0.0
for k, i in enumerate(got):
    end = got[k + 1] if k + 1 < len(got) else n
    d = dir0[i]
    for j in range(i, min(end, i + 800)):
        t = (j - i) * PERIOD_S
        want = d * 0.3 * (math.exp(-t / TD) - math.exp(-t / TR)) / PEAK
        highest = max(highest, abs(off2[j]))
        if abs(off2[j] - want) > TOL:
            rise_ok = False
            print(f"  instance 2 row {j}: offset {off2[j]}, want {want:.6f}")
print(f"instance 2 = 0.3 (exp(-t / 40 ms) - exp(-t / 10 ms)) / peak from each reversal: {yes(rise_ok)}")
print(f"instance 2 starts at 0: {yes(all(off2[i] == 0.0 for i in got))}")
print(f"instance 2 highest |offset| {highest:.4f} (amplitude 0.3, peak at {TP * 1e3:.2f} ms)")
