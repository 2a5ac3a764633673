#!/usr/bin/env python3
"""Reads spincal's ArduPilot and PX4 thermal parameter files back as the stacks would, and applies
them as the stacks' C++ does, independently of spincal (numpy only).

Usage: flight_stack_readback.py ARDUPILOT.param PX4.params --caltemp T[,T...] > readback.csv

The fixture crates/spincal/tests/fixtures/flight_stacks/readback.csv was made, from the root, by
  .venv/bin/python bench/thermal/flight_stack_readback.py \\
    crates/spincal/tests/fixtures/flight_stacks/ardupilot.param \\
    crates/spincal/tests/fixtures/flight_stacks/px4.params \\
    --caltemp 25,31.5,-300 > crates/spincal/tests/fixtures/flight_stacks/readback.csv

Parsing as the ground stations do: ArduPilot's file as MAVProxy's `param load` (lines starting with
`#` skipped, commas read as spaces, two fields); PX4's as QGroundControl (lines starting with `#`
skipped, five tab-separated fields: system, component, name, value, MAV_PARAM_TYPE).

The stacks' corrections (my reading of their sources):
- ArduPilot, AP_InertialSensor_tempcal.cpp (TCal::correct_sensor): with T and the accel
  calibration temperature T_cal (INS_ACCn_CALTEMP; -300 when never set) each clamped to
  [TMIN, TMAX], a -= P(T - 35); a += P(T_cal - 35), P(x) = (c1 + (c2 + c3 x) x) x * 1e-6, c_j the
  INS_TCALn_ACCj_{X,Y,Z}. Applied only when INS_TCALn_ENABLE is 1.
- PX4, TemperatureCompensation.cpp (calc_thermal_offsets_3D) and calibration::Accelerometer::Correct:
  d = TMAX - TREF above TMAX, TMIN - TREF below TMIN, else T - TREF; offset = x0 + x1 d + x2 d^2 +
  x3 d^3 (d^2 = d d, d^3 = d^2 d); a -= offset. Applied when TC_A_ENABLE is 1, to the sensor whose
  device id is TC_An_ID.
Both stacks compute in float (32 bits): out32_* repeats that arithmetic in numpy float32, out_* is
the same formula in float64.

Grid: temperatures from TMIN - 8 to TMAX + 8 in 81 steps plus TMIN and TMAX themselves; three
readings of float32-exact values (m/s^2); for ArduPilot each --caltemp value.

Output CSV: stack,temp_c,caltemp_c,mx,my,mz,out_x,out_y,out_z,out32_x,out32_y,out32_z
(caltemp_c is nan for PX4).
"""
import argparse
import re
import sys

import numpy as np

AXES = "XYZ"
READINGS = [(0.0, 0.0, 9.8125), (-9.8125, 0.0, 0.0), (-3.25, 5.125, -7.875)]


def read_mavproxy(path):
    params = {}
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line[0] == "#":
                continue
            fields = line.replace(",", " ").split()
            if len(fields) != 2:
                sys.exit(f"{path}: not a NAME,VALUE line: {line!r}")
            params[fields[0]] = float(fields[1])
    return params


def read_qgc(path):
    params = {}
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if line.startswith("#"):
                continue
            fields = line.split("\t")
            if len(fields) != 5:
                sys.exit(f"{path}: not a 5-field line: {line!r}")
            kind = int(fields[4])
            value = int(fields[3]) if kind == 6 else float(fields[3])
            params[fields[2]] = (value, kind)
    return params


def ardupilot(params, n, temp, caltemp, reading, f):
    """The reading after ArduPilot's temperature correction, in number type f."""
    p = lambda name: f(params[f"INS_TCAL{n}_{name}"])
    if params[f"INS_TCAL{n}_ENABLE"] != 1:
        return np.array(reading, dtype=f)
    tmin, tmax = p("TMIN"), p("TMAX")
    c = [np.array([p(f"ACC{j}_{a}") for a in AXES], dtype=f) for j in (1, 2, 3)]

    def poly(tdiff):
        return (c[0] + (c[1] + c[2] * tdiff) * tdiff) * tdiff * f(1.0e-6)

    t = min(max(f(temp), tmin), tmax)
    t_cal = min(max(f(caltemp), tmin), tmax)
    v = np.array(reading, dtype=f)
    v = v - poly(f(t - f(35.0)))
    v = v + poly(f(t_cal - f(35.0)))
    return v


def px4(params, n, temp, reading, f):
    """The reading after PX4's thermal offset (CAL_ACC offset 0, scale 1), in number type f."""
    if params["TC_A_ENABLE"][0] != 1:
        return np.array(reading, dtype=f)
    p = lambda name: f(params[f"TC_A{n}_{name}"][0])
    tmin, tmax, tref = p("TMIN"), p("TMAX"), p("TREF")
    x = [np.array([p(f"X{j}_{k}") for k in range(3)], dtype=f) for j in range(4)]
    temp = f(temp)
    if temp > tmax:
        d = f(tmax - tref)
    elif temp < tmin:
        d = f(tmin - tref)
    else:
        d = f(temp - tref)
    d2 = f(d * d)
    d3 = f(d2 * d)
    offset = x[0] + x[1] * d + x[2] * d2 + x[3] * d3
    return np.array(reading, dtype=f) - offset


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ardupilot")
    parser.add_argument("px4")
    parser.add_argument("--caltemp", required=True, help="INS_ACCn_CALTEMP values, comma separated")
    args = parser.parse_args()
    caltemps = [float(t) for t in args.caltemp.split(",")]

    ap = read_mavproxy(args.ardupilot)
    ap_n = [int(m.group(1)) for m in map(re.compile(r"^INS_TCAL(\d)_ENABLE$").match, ap) if m]
    qgc = read_qgc(args.px4)
    px4_n = [int(m.group(1)) for m in map(re.compile(r"^TC_A(\d)_ID$").match, qgc) if m]
    if len(ap_n) != 1 or len(px4_n) != 1:
        sys.exit("expected one INS_TCALn and one TC_An set")
    ap_n, px4_n = ap_n[0], px4_n[0]

    def grid(tmin, tmax):
        return sorted(set(np.linspace(tmin - 8.0, tmax + 8.0, 81).tolist()) | {tmin, tmax})

    def fmt(values):
        return ",".join(repr(float(v)) for v in values)

    print("stack,temp_c,caltemp_c,mx,my,mz,out_x,out_y,out_z,out32_x,out32_y,out32_z")
    ap_range = (ap[f"INS_TCAL{ap_n}_TMIN"], ap[f"INS_TCAL{ap_n}_TMAX"])
    for caltemp in caltemps:
        for temp in grid(*ap_range):
            for reading in READINGS:
                out = ardupilot(ap, ap_n, temp, caltemp, reading, np.float64)
                out32 = ardupilot(ap, ap_n, temp, caltemp, reading, np.float32)
                print(f"ardupilot,{fmt([temp, caltemp, *reading, *out, *out32])}")
    px4_range = (qgc[f"TC_A{px4_n}_TMIN"][0], qgc[f"TC_A{px4_n}_TMAX"][0])
    for temp in grid(*px4_range):
        for reading in READINGS:
            out = px4(qgc, px4_n, temp, reading, np.float64)
            out32 = px4(qgc, px4_n, temp, reading, np.float32)
            print(f"px4,{fmt([temp, float('nan'), *reading, *out, *out32])}")


if __name__ == "__main__":
    main()
