"""The JSON output of ``k37 run``: its schema, defined once, and a checker for it.

:data:`RUN_SCHEMA` is a JSON Schema (draft 2020-12 subset: type, properties, required, items,
enum, description). :func:`validate` checks a report against it; ``docs/run-json.md`` is
generated from it by :func:`schema_markdown`.
"""

from __future__ import annotations

from typing import Any

from k37.sim.backends.factory import BACKENDS

__all__ = ["BALLBAR_FIGURES", "RUN_SCHEMA", "SCHEMA_VERSION", "schema_markdown", "validate"]

SCHEMA_VERSION = 3
#: Fields that depend on how the run was computed (backend, idle skipping, wall clock), not
#: on what it computed: two runs of one job differ in these only.
HOW_FIELDS = ("wall_seconds", "cycles_per_second", "backend", "backend_reason",
              "skipped_cycles")


#: The figures of a ballbar test (:func:`k37.sim.run.ballbar.ballbar`), with their meaning.
BALLBAR_FIGURES = {
    "nominal_radius": "the programmed circle's radius (LSB)",
    "ballbar_samples": "samples analysed",
    "ballbar_sweep": "degrees the analysed samples cover (without the feed-in and feed-out, "
                     "or after the settle angle)",
    "path_speed": "the tool's median speed round the circle (over 20 ms windows, LSB/s)",
    "mean_radius_deviation": "mean radial deviation (LSB; negative: the circle shrank)",
    "circularity": "largest minus least radial deviation (LSB)",
    "centre_offset": "first harmonic of the radial deviation: the centre's offset (LSB)",
    "two_theta_amplitude": "second harmonic's amplitude: the mismatch ellipse (LSB)",
    "two_theta_angle": "direction of the ellipse's long axis (degrees, 0-180)",
    **{f"reversal_spike_{q}": f"largest deviation from the fit within 5 degrees of {q} "
                              f"degrees (LSB); null when the analysed arc does not sweep "
                              f"across {q} degrees" for q in (0, 90, 180, 270)},
}

#: Why the path's contour error is null.
_UNSAMPLED = "over a link: the samples are the served machine's, not the host's"


def _nullable(schema: dict, why: str) -> dict:
    """``schema`` that may also be null, saying when."""
    return {**schema, "type": [schema["type"], "null"],
            "description": f"{schema['description']}; null: {why}"}


def _obj(description: str, props: dict[str, dict], required: list[str] | None = None) -> dict:
    return {"type": "object", "description": description, "properties": props,
            "required": list(props) if required is None else required}


def _num(description: str, kind: str = "number") -> dict:
    return {"type": kind, "description": description}


def _int(description: str) -> dict:
    return _num(description, "integer")


def _xy(description: str) -> dict:
    return {"type": "array", "description": description, "items": {"type": "integer"}}


_STEPS = _obj("step pulses the K3701 emitted in the block, per axis and direction (z+ and "
              "z- on three axes)",
              {k: _int(f"{k} pulses") for k in ("x+", "x-", "y+", "y-", "z+", "z-")},
              required=["x+", "x-", "y+", "y-"])

_AXIS = _obj("one axis at the end of the run", {
    "command": _nullable(_int("K3702 command counter (LSB)"), "the link was lost"),
    "error": _nullable(_int("K3702 error counter (LSB)"), "the link was lost"),
    "actual": _nullable(_int("plant encoder count, the true position (LSB)"),
                        "the link was lost"),
    "max_abs_error": {"type": ["integer", "null"],
                      "description": "largest absolute error at any cycle of the run (LSB; "
                                     "null: over a link to a real board)"},
    "flags": _obj("K3702 STATUS fields", {
        k: _int(k) for k in ("in_position", "negative", "sat_pos", "sat_neg", "alarm", "irq",
                             "bad_config")}, required=[]),
})

RUN_SCHEMA: dict[str, Any] = _obj("result of `k37 run`", {
    "schema_version": _int(f"version of this schema ({SCHEMA_VERSION})"),
    "job": {"type": "object", "description": "the job's configuration as run"},
    "status": {"type": "string",
               "enum": ["ok", "alarm", "fault", "timeout", "interrupted", "stalled",
                        "link-lost"],
               "description": "ok; alarm: a K3702 alarm stopped the feed; fault: an "
                              "interpolator error, FP overrun, encoder fault or settle "
                               "timeout, or over a link the board's watchdog, E-stop or a "
                               "limit stopped the machine; link-lost: over a link, the link "
                               "failed during the run (what was not read is null); "
                               "timeout: a limit ran out (--max-cycles, or the job's "
                               "run.max_time_s of simulated time); interrupted: a stop was "
                               "requested (Ctrl-C); stalled: a block made no progress (no "
                               "feed pulse, no axis motion) for its stall time, the reason "
                               "names the block and its line"},
    "reason": {"type": "string", "description": "why the run ended, in words (which alarm, "
                                                "fault or limit, at which cycle)"},
    "backend": {"type": "string", "enum": [*BACKENDS, "link"],
                "description": "simulation backend used; link: the firmware ran over a link "
                               "(`--link`), the machine elsewhere"},
    "backend_reason": {"type": "string", "description": "why that backend ran (`--backend`, "
                                                       "or what `auto` looked at)"},
    "cycles": _int("system clock cycles simulated"),
    "clock_hz": _num("system clock (Hz)"),
    "machine_seconds": _num("simulated time, cycles / clock_hz (s)"),
    "wall_seconds": _num("wall-clock time of the simulation (s; build excluded)"),
    "cycles_per_second": _num("cycles / wall_seconds"),
    "skipped_cycles": _int("cycles of `cycles` proved idle and advanced without evaluation "
                           "(identical results; 0 on pysim or with --no-skip-idle)"),
    "blocks": {"type": "array", "description": "one entry per motion block run",
               "items": _obj("a block", {
                   "index": _int("position in the program (0-based, dwells counted)"),
                   "line": _int("G-code line number"),
                   "kind": {"type": "string", "enum": ["linear", "circular", "parabolic",
                                                     "exponential"],
                            "description": "interpolation type"},
                   "start_cycle": _int("cycle the firmware began loading it"),
                   "end_cycle": {"type": ["integer", "null"],
                                 "description": "cycle its data-request interrupt was served "
                                                "(null: it did not end)"},
                   "fp_budget": _int("FP loaded into the decel control"),
                   "fp_pulses": {"type": ["integer", "null"],
                                 "description": "FP the K3701 received during the block "
                                                "(null: over a link to a real board)"},
                   "feed_word": _int("18-bit rate multiplier word"),
                   "steps": {**_STEPS, "type": ["object", "null"]},
                   "end_command": {"type": ["array", "null"], "items": {"type": "integer"},
                                   "description": "interpolated position at the block's end "
                                                  "(LSB, from the step pulses)"},
               })},
    "axes": _obj("per-axis state (z on a three-axis machine, job.machine.axes = 3)",
                 {"x": _AXIS, "y": _AXIS, "z": _AXIS}, required=["x", "y"]),
    "end_point": _obj("whether the machine reached the program's end point", {
        "programmed": _xy("the last move's end (LSB), one value per axis"),
        "actual": {**_xy("the plants' encoder counts at the end of the run (LSB), one per "
                         "axis; null: the link was lost"),
                   "items": {"type": ["integer", "null"]}},
        "program_ran": {"type": "boolean", "description": "every block of the program ran to "
                                                          "its end"},
        "reached": {"type": "boolean", "description": "program_ran, and every axis within the "
                                                      "in-position zone (machine.in_position) "
                                                      "of the end point"},
    }),
    "path": _obj("contour error: distance from each actual sample to the programmed path", {
        "max_contour_error": _nullable(_num("largest (LSB)"), _UNSAMPLED),
        "rms_contour_error": _nullable(_num("root mean square (LSB)"), _UNSAMPLED),
        "samples": _int("samples taken"),
    }),
    "alarms": {"type": "array", "description": "alarms and faults, in order",
               "items": _obj("an alarm or fault", {
                   "axis": {"type": ["string", "null"], "description": "x, y, z or null"},
                   "cycle": _int("cycle the firmware saw it"),
                   "kind": {"type": "string", "description": "alarm, interpolator_error, "
                            "fp_overrun, encoder_line_fault_a, encoder_line_fault_b, "
                            "encoder_quad_error, settle_timeout"},
               })},
    "warnings": {"type": "array", "items": {"type": "string"},
                 "description": "what the run could not do as asked (e.g. a waveform window "
                                "it never reached)"},
    "ballbar": _obj("ballbar figures of a circular program (only with --ballbar)",
                    {name: {"type": ["number", "null"], "description": text}
                     if name.startswith("reversal_spike") else _num(text)
                     for name, text in BALLBAR_FIGURES.items()}),
    "events": {"type": "array", "description": "words with no hardware here (spindle, coolant, "
                                               "tool change, stops), in order; only when the "
                                               "program has some",
               "items": _obj("an event", {
                   "line": _int("G-code line number"),
                   "word": {"type": "string", "description": "the word, as written (M03, T2)"},
                   "kind": {"type": "string", "description": "its meaning (docs/gcode.md)"},
                   "value": {"type": ["number", "null"], "description": "S or T value"},
                   "cycle": _int("cycle the firmware reached it at"),
               })},
})
RUN_SCHEMA["properties"]["link"] = _obj(
    "the link the firmware ran over (only with `--link`)", {
        "url": {"type": "string", "description": "the link's URL"},
        "probes": {"type": "boolean", "description": "the far end answered PROBE (a simulated "
                                                     "board): the blocks' pulses are known"},
        "board_cycle": _nullable(_int(
            "the bridge's cycle counter at the end (modulo 2^40): ahead of `cycles` by the "
            "time bytes spent on the line"), "the link was lost"),
        "board_cycles": _nullable(_int(
            "the board's own count of the firmware's run, from its bridge's cycle counter: "
            "`cycles` is the host's count, which misses the time bytes spend on the line"),
            "the link was lost"),
        "board": {"type": ["object", "null"],
                  "description": "the board's STATUS when the run ended, by field "
                                 "(docs/registers.md, BOARD): its latched watchdog, E-stop "
                                 "and limit bits, the E-stop input and drive-enable; null: "
                                 "the link was lost"},
        "watchdog_cycles": _int("the board's watchdog time the host armed for the run "
                                "(`--watchdog`, in cycles; 0: not armed)"),
        "board_blocks": {"type": "array", "items": {"type": ["array", "null"]},
                         "description": "each block's start and end cycle on the board, by "
                                        "PROBE or, from a board without it, by its bridge's "
                                        "cycle counter (the end null: the block did not end)"},
        "stop_seen": _nullable(_obj(
            "where the host, reading the board's STATUS while it waited, saw a latched stop "
            "and ended the run (only with `--watchdog`)", {
                "cycle": _int("the host's count of cycles at the STATUS read"),
                "board_cycle": _int("the bridge's cycle counter just after it"),
            }), "no stop was seen during the run"),
    }, required=["url", "probes", "board_cycle", "board_cycles", "board", "watchdog_cycles",
                 "board_blocks"])
#: Present only when asked for (ballbar), when there are some (events), with ``--link`` or
#: when a backend was picked (backend_reason).
OPTIONAL = ("ballbar", "events", "link", "backend_reason")
RUN_SCHEMA["required"] = [key for key in RUN_SCHEMA["required"] if key not in OPTIONAL]

_TYPES = {"object": dict, "array": list, "string": str, "integer": int, "number": (int, float),
          "boolean": bool, "null": type(None)}


def validate(value: Any, schema: dict = RUN_SCHEMA, where: str = "$") -> None:
    """Raise ValueError naming the first place where ``value`` breaks ``schema``."""
    kinds = schema.get("type")
    if kinds is not None:
        kinds = [kinds] if isinstance(kinds, str) else kinds
        ok = any(isinstance(value, _TYPES[k]) and not (k in ("integer", "number")
                                                      and isinstance(value, bool))
                 for k in kinds)
        if not ok:
            raise ValueError(f"{where}: expected {' or '.join(kinds)}, got {value!r}")
    if "enum" in schema and value not in schema["enum"]:
        raise ValueError(f"{where}: {value!r} is not one of {schema['enum']}")
    if isinstance(value, dict) and "properties" in schema:
        for key in schema.get("required", []):
            if key not in value:
                raise ValueError(f"{where}: missing key {key!r}")
        for key, sub in schema["properties"].items():
            if key in value:
                validate(value[key], sub, f"{where}.{key}")
    if isinstance(value, list) and "items" in schema:
        for k, item in enumerate(value):
            validate(item, schema["items"], f"{where}[{k}]")


def schema_markdown() -> str:
    """``docs/run-json.md``: every key of the report with its type and meaning."""
    lines = ["# `k37 run --json` output", "",
             f"Generated from `sim/run/report.py` (schema version {SCHEMA_VERSION}; do not edit "
             "by hand).", "", "| key | type | meaning |", "|---|---|---|"]

    def walk(schema: dict, path: str) -> None:
        kinds = schema.get("type", "")
        kinds = kinds if isinstance(kinds, str) else " or ".join(kinds)
        desc = schema.get("description", "")
        if "enum" in schema:
            desc += f" ({', '.join(map(str, schema['enum']))})"
        if path:
            lines.append(f"| `{path}` | {kinds} | {desc} |")
        for key, sub in schema.get("properties", {}).items():
            walk(sub, f"{path}.{key}" if path else key)
        if "items" in schema and "properties" in schema["items"]:
            walk(schema["items"], f"{path}[]")

    walk(RUN_SCHEMA, "")
    return "\n".join(lines) + "\n"
