"""A lab's own files: delimiters, preambles, column maps, units, .npz/.mat, preprocessing, and the
simulate / validate / report commands on a saved result."""

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import dcjax
from dcjax import Recording, datasets, load_recording, load_result
from dcjax.analysis.checks import check_recording
from dcjax.cli import main
from dcjax.io.table import read_table
from dcjax.io.units import named_columns

RPM = 2 * np.pi / 60


def write_daq(path: Path, rec: Recording, delimiter=";", decimal="."):
    """SD1 as a DAQ would export it: a preamble, `;`, time in ms, current in mA, speed in rpm and
    an extra column."""
    rows = [
        "# exported by LabDAQ 3.2",
        "Device: bench 4; channel setup A",
        "Sample rate: 10 kHz",
        delimiter.join(["time_ms", "U_arm_V", "I_arm_mA", "speed_rpm", "temp_C"]),
    ]
    for k in range(len(rec)):
        vals = [rec.t[k] * 1e3, rec.u_a[k], rec.i_a[k] * 1e3, rec.omega[k] / RPM, 21.5]
        text = [repr(float(v)) for v in vals]
        if decimal == ",":
            text = [t.replace(".", ",") for t in text]
        rows.append(delimiter.join(text))
    path.write_text("\n".join(rows) + "\n")


COLUMNS = {"t": "time_ms", "u_a": "U_arm_V", "i_a": "I_arm_mA", "omega": "speed_rpm"}
UNITS = {"t": "ms", "i_a": "mA", "omega": "rpm"}


@pytest.mark.parametrize("delimiter,decimal", [(";", "."), ("\t", "."), (",", "."), (";", ","), (" ", ".")])
def test_daq_file_loads_to_the_same_recording(tmp_path, sd1, delimiter, decimal):
    f = tmp_path / "daq.txt"
    write_daq(f, sd1, delimiter, decimal)
    rec = load_recording(f, columns=COLUMNS, units=UNITS, decimal=decimal)
    for c in ("u_a", "i_a", "omega"):
        np.testing.assert_allclose(rec[c], sd1[c], rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(rec.t, sd1.t, rtol=1e-14, atol=1e-18)
    src = rec.metadata["source"]
    assert src["sha256"] and Path(src["path"]).name == "daq.txt" and src["load"]["units"] == UNITS
    detected = load_recording(f, columns=COLUMNS, units=UNITS)  # the decimal separator not given: detected
    for c in ("t", "u_a", "i_a", "omega"):
        np.testing.assert_array_equal(detected[c], rec[c])


def test_a_loggers_timestamps_read_as_seconds_after_the_first(tmp_path, sd1):
    """A column of ISO 8601 timestamps (`2026-12-06 08:00:00.000100`, `...T...Z`), day.month.year
    ones (`06.12.2026 23:59:59,99`, `7.12.2026 0:00:00.01`) or times of day (`23:59:59,9999`
    with a decimal comma, `9:59:59.99`) is the time in seconds after its first one, exact to the
    microsecond (it said "cannot detect the delimiter"), a time of day past midnight too; `timestamp`
    names the time column. Mixed time zones are a text cell: one line naming the line. A slashed
    date reads month or day first by the step past midnight (`12/6/2026 11:59:59.99 PM` then
    `12/7/2026 12:00:00.00 AM` is a day later; `6/12/2026` then `7/12/2026` too), year first as
    year/month/day; one that does not read is one line saying how it may be written."""
    import datetime

    n = 200
    start = datetime.datetime(2026, 12, 6, 23, 59, 59, 990000)  # over midnight and into a new day
    stamps = [start + datetime.timedelta(microseconds=round(float(v) * 1e6)) for v in sd1.t[:n]]
    body = [(sd1.u_a[k], sd1.i_a[k], sd1.omega[k]) for k in range(n)]

    def written(name, header, stamp, sep=",", comma=False):
        rows = [
            sep.join([stamp(s), *(repr(float(v)).replace(".", ",") if comma else repr(float(v)) for v in b)]) for s, b in zip(stamps, body)
        ]
        f = tmp_path / name
        f.write_text("\n".join([f"# logger started {stamps[0]}", header, *rows]) + "\n")
        return f

    for f in (
        written("iso.csv", "timestamp,u_a,i_a,omega", lambda s: s.isoformat(sep=" ", timespec="microseconds")),
        written("zulu.csv", "t,u_a,i_a,omega", lambda s: s.isoformat(timespec="microseconds") + "Z"),
        written("eu.csv", "time;u_a;i_a;omega", lambda s: (s - datetime.timedelta(days=1)).strftime("%H:%M:%S,%f"), sep=";", comma=True),
        written("de.csv", "time;u_a;i_a;omega", lambda s: s.strftime("%d.%m.%Y %H:%M:%S,%f"), sep=";", comma=True),
        written("de-short.csv", "time,u_a,i_a,omega", lambda s: f"{s.day}.{s.month}.{s.year} {s.hour}:{s:%M:%S.%f}"),
        written("hour.csv", "time,u_a,i_a,omega", lambda s: f"{(s.hour + 10) % 24}:{s:%M:%S.%f}"),  # 9:59:59.99: one digit
    ):
        rec = load_recording(f)
        assert np.max(np.abs(rec.t - sd1.t[:n])) < 1e-15 and rec.t[0] == 0.0, f.name
        np.testing.assert_array_equal(rec.i_a, sd1.i_a[:n])
    mixed = written("mixed.csv", "timestamp,u_a,i_a,omega", lambda s: s.isoformat() + ("Z" if s == stamps[7] else ""))
    with pytest.raises(
        dcjax.DataError, match=r"mixed.csv: line 10: field 0 \('2026-12-06T23:59:59.990700Z'\) is a timestamp that cannot follow"
    ):
        load_recording(mixed)
    for f in (
        written("us.csv", "time,u_a,i_a,omega", lambda s: f"{s.month}/{s.day}/{s.year} {s:%H:%M:%S.%f}"),
        written("us-12h.csv", "time,u_a,i_a,omega", lambda s: f"{s.month}/{s.day}/{s.year} {s:%I:%M:%S.%f} {s:%p}"),
        written("uk.csv", "time;u_a;i_a;omega", lambda s: f"{s:%d/%m/%y %H:%M:%S,%f}", sep=";", comma=True),
        written("ymd.csv", "time,u_a,i_a,omega", lambda s: f"{s:%Y/%m/%d %H:%M:%S.%f}"),
    ):
        rec = load_recording(f)
        assert np.max(np.abs(rec.t - sd1.t[:n])) < 1e-15 and rec.t[0] == 0.0, f.name
    same_day = written("day.csv", "time,u_a,i_a,omega", lambda s: f"{s:%m/%d/%Y %H:%M:%S.%f}".replace("12/0", "11/0"))
    assert np.max(np.abs(load_recording(same_day).t - sd1.t[:n])) < 1e-15  # 11/06 then 11/07: a day in one order, a month in the other
    dashed = written("dashed.csv", "time,u_a,i_a,omega", lambda s: f"{s.month}/{s.day}/{s.year}-{s:%H:%M:%S.%f}")
    with pytest.raises(dcjax.DataError, match=r"dashed.csv: the last line holds a date with slashes \('12/7/2026'\).*ISO 8601"):
        load_recording(dashed)


@pytest.mark.slow  # a CLI fit; the fast run's DAQ test detects the comma too
def test_a_decimal_comma_is_detected_where_the_rows_are_numbers_only_with_it(tmp_path, sd1):
    """A European spreadsheet's export (`0,0001;220;0,5`) loads without `decimal=","`, also where
    the last rows hold integers only (`220;0;0`: the comma shows higher up); with `decimal="."`
    given it stays a one-line error. The command line fits it with no `--decimal`."""

    def euro(k, channels):
        return ";".join(repr(float(sd1[c][k])).replace(".", ",") for c in channels)

    f = tmp_path / "euro.csv"
    f.write_text("t;u_a;i_a;omega\n" + "\n".join(euro(k, ("t", "u_a", "i_a", "omega")) for k in range(len(sd1))) + "\n")
    rec = load_recording(f)
    for c in ("t", "u_a", "i_a", "omega"):
        np.testing.assert_array_equal(rec[c], sd1[c])
    with pytest.raises(dcjax.DataError, match="cannot detect the delimiter"):
        load_recording(f, decimal=".")
    still = tmp_path / "still.csv"  # no time column (dt given); the motor held at rest at the end
    still.write_text(
        "u_a;i_a;omega\n" + "\n".join([*(euro(k, ("u_a", "i_a", "omega")) for k in range(len(sd1))), "220;0;0", "220;0;0"]) + "\n"
    )
    rec = load_recording(still, dt=1e-4)
    np.testing.assert_array_equal(rec.omega[: len(sd1)], sd1.omega)
    assert rec.omega[-1] == 0.0 and len(rec) == len(sd1) + 2
    out = tmp_path / "fit"
    assert main(["fit", str(f), "--runs", "1", "--budget", "300", "--out", str(out)]) == 0
    assert json.loads((out / "result.json").read_text())["of"] < 1e-6  # SD1 read whole: the fit follows it


@pytest.mark.parametrize("cut", ["0.05,220,0.3", "0.05,220,0.3,1.2e", "0.05;220"], ids=["a-field-short", "a-number-short", "mid-field"])
def test_a_last_row_cut_short_is_named_not_read_as_the_shape_of_the_data(tmp_path, sd1, cut):
    """A logger stopped mid-line (or a file copied while being written) ends in a row cut short:
    the rows above it set the data's shape and the last line is the one-line error, which says so
    (it read the last line's 3 fields as the shape and said "no column 't'; the columns are '0',
    '1', '2'"). A file of one data row under a units line keeps its shape from that row."""
    f = tmp_path / "cut.csv"
    rows = [",".join(repr(float(sd1[c][k])) for c in ("t", "u_a", "i_a", "omega")) for k in range(50)]
    f.write_text("t,u_a,i_a,omega\n" + "\n".join(rows) + f"\n{cut}\n# stopped\n")
    with pytest.raises(dcjax.DataError, match=r"cut\.csv: line 52.*the file's last row, cut short") as e:
        load_recording(f)
    assert "no column" not in str(e.value)
    assert main(["fit", str(f), "--runs", "1", "--budget", "100", "--out", str(tmp_path / "o")]) == 2
    one = tmp_path / "one.csv"
    one.write_text("t,u_a,i_a,omega\ns,V,A,rad/s\n0,220,0,0\n")
    table = read_table(one)
    assert list(table.columns) == ["t", "u_a", "i_a", "omega"] and table.units["omega"] == "rad/s"


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16-le", "utf-16-be"])
@pytest.mark.parametrize("rows", [300, 2000], ids=["short", "beyond-the-sniffed-tail"])
def test_a_file_with_a_byte_order_mark_loads_as_without(tmp_path, sd1, encoding, rows):
    """Excel's "CSV UTF-8" starts with a UTF-8 byte-order mark, Windows tools write UTF-16 with
    one: the header's first name is not the mark plus `time_ms`, and a file longer than the tail
    read to detect the delimiter reads the same. A sidecar with a mark reads; one that is not
    UTF-8 is a one-line error naming it."""
    plain, marked = tmp_path / "plain.txt", tmp_path / "marked.txt"
    tiled = {c: np.resize(sd1[c], rows) for c in ("u_a", "i_a", "omega")}  # SD1's 500 samples over and over
    write_daq(plain, Recording(t=np.arange(rows) * (sd1.t[1] - sd1.t[0]), **tiled, name="SD1"))
    text = plain.read_text().split("\n", 3)[3]  # the header first: the mark is glued to its first name
    plain.write_text(text)
    mark = "" if encoding == "utf-8-sig" else "\ufeff"  # Python writes UTF-8's mark itself, UTF-16's not in a fixed byte order
    marked.write_bytes((mark + text).encode(encoding))
    assert marked.read_bytes()[:2] in (b"\xef\xbb", b"\xff\xfe", b"\xfe\xff") and marked.stat().st_size > (65536 if rows > 300 else 0)
    a, b = (load_recording(f, columns=COLUMNS, units=UNITS) for f in (plain, marked))
    for c in ("t", "u_a", "i_a", "omega"):
        np.testing.assert_array_equal(a[c], b[c])
    marked.with_suffix(".json").write_bytes('{"name": "Motor é", "i_a_limit": 2.5}'.encode("utf-8-sig"))
    named = load_recording(marked, columns=COLUMNS, units=UNITS)
    assert named.name == "Motor é" and named.limit == 2.5
    marked.with_suffix(".json").write_bytes('{"name": "Motor é"}'.encode("latin-1"))
    with pytest.raises(dcjax.DataError, match=r"marked.json: not UTF-8 text \(byte 16\); save it as UTF-8$"):
        load_recording(marked, columns=COLUMNS, units=UNITS)


def _quoted(text: str) -> str:
    return '"' + text.replace('"', '""') + '"'


@pytest.mark.parametrize("form", ["every-field", "decimal-comma", "whitespace", "name-comma-unit"])
def test_a_file_with_quoted_fields_loads_as_without(tmp_path, sd1, form):
    """Fields in double quotes (RFC 4180) read as their text, a delimiter inside them included:
    every field quoted (a spreadsheet's "quote all"); a decimal comma quoted between commas
    (`"0,0001",220`: a German-locale spreadsheet's export, the decimal comma detected); quoted
    fields between spaces; a logger's `"Time, s"` headers under a quoted title line (`""` a quote
    in it), the unit after the comma read as `Time [s]`'s (the time found by its name, the
    others' units the ones given). Each gives SD1's bits. Without the
    quotes a comma that is both delimiter and decimal separator stays a one-line error."""
    channels = ("t", "u_a", "i_a", "omega")
    values = [[repr(float(sd1[c][k])) for c in channels] for k in range(len(sd1))]
    if form == "every-field":
        text = [",".join(map(_quoted, channels))] + [",".join(map(_quoted, row)) for row in values]
    elif form == "decimal-comma":
        text = [",".join(channels)] + [",".join(_quoted(v.replace(".", ",")) if "." in v else v for v in row) for row in values]
    elif form == "whitespace":
        text = [" ".join(map(_quoted, channels))] + ["  ".join(map(_quoted, row)) for row in values]
    else:
        heads = ["#", "Time, s", "Voltage, V", "Current, mA", "Speed, rpm"]
        rows = [[str(k + 1), v[0], v[1], repr(float(sd1.i_a[k]) * 1e3), repr(float(sd1.omega[k]) / RPM)] for k, v in enumerate(values)]
        text = [_quoted('Plot title: "bench 4"'), ",".join(map(_quoted, heads))] + [",".join(row) for row in rows]
    f = tmp_path / "quoted.csv"
    f.write_text("\n".join(text) + "\n")
    kw = dict(columns={"u_a": "Voltage, V", "i_a": "Current, mA", "omega": "Speed, rpm"}, units={"i_a": "mA", "omega": "rpm"})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the units given are the ones the headers state: no warning
        rec = load_recording(f, **(kw if form == "name-comma-unit" else {}))
    for c in channels:
        if form == "name-comma-unit" and c in ("i_a", "omega"):
            np.testing.assert_allclose(rec[c], sd1[c], rtol=1e-14, atol=1e-300)
        else:
            np.testing.assert_array_equal(rec[c], sd1[c])
    if form == "decimal-comma":
        bare = tmp_path / "bare.csv"
        bare.write_text("t,u_a\n0,0001,220\n0,0002,220\n")
        with pytest.raises(dcjax.ConfigError, match="cannot both be ','"):
            load_recording(bare, delimiter=",", decimal=",")


def test_npz_mat_and_dataframe(tmp_path, sd1):
    np.savez(tmp_path / "r.npz", time=sd1.t, u=sd1.u_a, i=sd1.i_a, n=sd1.omega / RPM)
    cols = {"t": "time", "u_a": "u", "i_a": "i", "omega": "n"}
    rec = load_recording(tmp_path / "r.npz", columns=cols, units={"omega": "1/min"})
    np.testing.assert_allclose(rec.omega, sd1.omega, rtol=1e-14)
    from scipy.io import savemat

    savemat(tmp_path / "r.mat", {"time": sd1.t, "u": sd1.u_a, "i": sd1.i_a, "n": sd1.omega / RPM})
    rec = load_recording(tmp_path / "r.mat", columns=cols, units={"omega": "rpm"})
    np.testing.assert_allclose(rec.i_a, sd1.i_a, rtol=1e-14)
    table = {"time": sd1.t * 1e3, "u": sd1.u_a, "i": sd1.i_a, "n": sd1.omega}
    rec = Recording.from_dataframe(table, columns=cols, units={"t": "ms"})
    np.testing.assert_allclose(rec.t, sd1.t, rtol=1e-14, atol=1e-18)


def test_preprocessing(tmp_path, sd1):
    f = tmp_path / "SD1.csv"
    dcjax.save_csv(sd1, f)
    rec = load_recording(f, window=(0.01, 0.03), every=2)
    assert rec.t[0] >= 0.01 and rec.t[-1] <= 0.03 and np.allclose(np.diff(rec.t), 2e-4)
    assert rec.metadata["source"]["load"] == {"window": [0.01, 0.03], "every": 2}


def test_npz_and_mat_files_read_as_their_columns_or_fail_naming_the_file(tmp_path, sd1):
    """A matrix in a .npz is one column per column, as in a .mat (it was flattened into one long
    column: "different lengths"); a file that is not a .npz, an object array (never unpickled)
    and a .mat of structs only are one-line errors naming the file (they were NumPy's words, or
    "the columns are " of nothing)."""
    from scipy.io import savemat

    np.savez(tmp_path / "m.npz", t=sd1.t, u=np.column_stack([sd1.u_a, sd1.i_a]), omega=sd1.omega, on=sd1.u_a > 0)
    rec = load_recording(tmp_path / "m.npz", columns={"u_a": "u[0]", "i_a": "u[1]"})
    np.testing.assert_array_equal(rec.i_a, sd1.i_a)
    flag = load_recording(tmp_path / "m.npz", columns={"u_a": "on", "i_a": "u[1]"})  # a logged flag reads as 0/1
    np.testing.assert_array_equal(flag.u_a, (sd1.u_a > 0).astype(float))
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    np.savez(tmp_path / "obj.npz", t=np.array([None, 1, 2], dtype=object))
    savemat(tmp_path / "s.mat", {"data": {"t": sd1.t, "u_a": sd1.u_a}})
    for name, match in [
        ("junk.npz", r"junk.npz: not a .npz archive \(a zip of named .npy arrays"),
        ("obj.npz", r"obj.npz: not a readable .npz file of numeric arrays \(Object arrays cannot be loaded"),
        ("s.mat", r"s.mat: no numeric array of more than one value at its top level; it holds data \(a struct\)$"),
    ]:
        with pytest.raises(dcjax.DataError, match=match):
            load_recording(tmp_path / name)


def test_a_folder_given_as_a_file_is_named_a_folder(tmp_path):
    """It said "no such file" of a folder that exists."""
    with pytest.raises(dcjax.DataError, match=r"is a folder: give its data files \(e.g. .*\*\.csv\)$"):
        load_recording(tmp_path)
    with pytest.raises(dcjax.DataError, match=r"^no such file: "):
        load_recording(tmp_path / "none.csv")


def test_a_header_naming_the_channels_but_for_case_or_an_si_unit_reads_as_the_plain_one(tmp_path, sd1):
    """`T,U_A,I_A,OMEGA` or `t [s],u_a (V),i_a_A,omega [rad/s]` (it said "no column 't'"): the
    same bits as the numbers written, no warning; the time also as `time` (`Time (s)`). A unit
    that is not the channel's SI unit (`time_ms`), or two columns that match, are one line saying
    how to map it; a word that is not the channel's name (`speed`) is not guessed."""
    n = 300
    rows = np.column_stack([sd1.t[:n], sd1.u_a[:n], sd1.i_a[:n], sd1.omega[:n]])

    def written(header: str) -> Path:
        f = tmp_path / f"{abs(hash(header))}.csv"
        cols = np.column_stack([rows, rows[:, 3:]]) if header.count(",") == 4 else rows
        f.write_text(header + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in cols) + "\n")
        return f

    for header in ("T,U_A,I_A,OMEGA", "t [s],u_a (V),i_a_A,omega [rad/s]", "Time (s),u_a,i_a,omega", "t,u_a,i_a,speed"):
        f = written(header)
        if header.endswith("speed"):
            with pytest.raises(dcjax.DataError, match=r"no column 'omega' for omega; the columns are 't', 'u_a', 'i_a', 'speed'"):
                load_recording(f)
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rec = load_recording(f)
        assert np.array_equal(np.column_stack([rec.t, rec.u_a, rec.i_a, rec.omega]), rows), header
    for header, match in [
        (
            "t [ms],u_a,i_a,omega",
            r"column 't \[ms\]' names t in ms, not s: map it with columns=\{'t': 't \[ms\]'\} and units=\{'t': 'ms'\}$",
        ),
        ("t,u_a,i_a,omega_rpm", r"column 'omega_rpm' names omega in rpm, not rad/s: map it with columns=\{'omega': 'omega_rpm'\}"),
        ("t [V],u_a,i_a,omega", r"column 't \[V\]' names t in V, not s: map t's column with columns=\{'t': NAME\}$"),
        ("t,u_a,i_a,Omega,OMEGA", r"'Omega' and 'OMEGA' both name it but for case or unit: map one with columns=\{'omega': NAME\}$"),
        (
            "time_ms,u_a,i_a,omega",
            r"^[0-9]+.csv: no column 't' for t; column 'time_ms' names t in ms, not s: map it with columns=\{'t': 'time_ms'\}",
        ),
    ]:
        with pytest.raises(dcjax.DataError, match=match):
            load_recording(written(header))
    rec = load_recording(written("time_ms,u_a,i_a,omega"), units={"t": "ms"})  # the unit given: the column is taken and converted
    np.testing.assert_allclose(rec.t, rows[:, 0] * 1e-3, rtol=1e-15)
    # a channel of no known quantity (the servo's mass m) is not read from a column that states a unit (a torque `M [Nm]`)
    taken, why = named_columns(["t", "M [Nm]", "M_2"], {"M [Nm]": "Nm"}, ["m"], {})
    assert taken == {} and why["m"] == (
        "column 'M [Nm]' states the unit Nm, and the model gives m no quantity to check it against (Model.quantities): "
        "map it with columns={'m': 'M [Nm]'} to read it as it is"
    )
    assert main(["fit", str(written("T,U_A,I_A,OMEGA")), "--bounds", "table4", "--runs", "1", "--budget", "70", "--plots", "none",
                 "--out", str(tmp_path / "out")]) == 0  # fmt: skip
    assert load_result(tmp_path / "out" / "result.json").recording.t[-1] == rows[-1, 0]  # the saved result reloads its file


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(columns=COLUMNS, units={"omega": "furlong"}), "unknown unit 'furlong' for omega; accepted: rad/s, 1/s, rpm"),
        (dict(units={"speed": "rpm"}), "unknown channel(s) 'speed'"),
        (dict(columns={"t": "time"}), "no column 'time' for t; the columns are 'time_ms'"),
        (dict(columns=COLUMNS, delimiter="|"), "delimiter must be one of"),
        (dict(columns=COLUMNS, delimiter=","), "no numeric data rows"),
        (dict(columns=COLUMNS, window="a:b"), "window must be T0:T1"),
    ],
)
def test_loading_errors_are_clear(tmp_path, sd1, kw, match):
    f = tmp_path / "daq.csv"
    write_daq(f, sd1)
    with pytest.raises(ValueError, match=match.replace("(", r"\(").replace(")", r"\)")):
        load_recording(f, **kw)


@pytest.mark.slow
def test_daq_sd1_fits_like_sd1_and_the_commands_work(tmp_path, capsys):
    """Issue 13's acceptance: the DAQ rewrite of SD1 fitted with --columns/--units gives SD1's
    parameters within 1e-9; then report, validate and simulate on the saved result."""
    sd1 = datasets.load("SD1")
    f = tmp_path / "bench4.csv"
    write_daq(f, sd1)
    args = ["--columns", "t=time_ms,u_a=U_arm_V,i_a=I_arm_mA,omega=speed_rpm", "--units", "t=ms,i_a=mA,omega=rpm"]
    assert main(["fit", str(f), *args, "--runs", "2", "--out", str(tmp_path / "daq")]) == 0
    assert main(["fit", "SD1", "--runs", "2", "--out", str(tmp_path / "sd1")]) == 0
    a = json.loads((tmp_path / "daq" / "result.json").read_text())
    b = json.loads((tmp_path / "sd1" / "result.json").read_text())
    for n in dcjax.DC.names:
        assert abs(a["params"][n] - b["params"][n]) <= 1e-9 * abs(b["params"][n]), n
    assert a["settings"]["data"][0]["sha256"] and a["dcjax_version"]
    capsys.readouterr()
    res = tmp_path / "daq" / "result.json"
    assert main(["report", str(res)]) == 0
    out = capsys.readouterr().out
    assert "[[Variables]]" in out and "fit % (bench4)" in out and "Ra:" in out
    assert main(["validate", str(res), "SD1", str(f), *args, "--out", str(tmp_path / "v")]) == 0
    rows = json.loads((tmp_path / "v" / "validation.json").read_text())
    assert [r["recording"] for r in rows] == ["SD1", "bench4"] and all(r["fit_percent"]["i_a"] > 99.99 for r in rows)
    assert main(["simulate", str(res), "SD1", "--out", str(tmp_path / "s")]) == 0
    sim = np.genfromtxt(tmp_path / "s" / "simulated_SD1.csv", delimiter=",", names=True)
    np.testing.assert_allclose(sim["i_a_sim"], sd1.i_a, rtol=1e-6, atol=1e-9)
    cells = [c for line in (tmp_path / "s" / "simulated_SD1.csv").read_text().splitlines()[1:] for c in line.split(",")]
    assert all(c == repr(float(c)) for c in cells) and "0.0001" in cells  # plain numbers, lossless: 0.0001, not 0.00010000000000000000
    r = load_result(res)
    assert r.recording is not None and r.recording.name == "bench4" and len(r.recording) == len(sd1)
    assert "fit %" in str(r)


@pytest.mark.parametrize(
    "args,match",
    [
        (
            ["fit", "FILE", "--columns", "t=time_ms,u_a=U_arm_V,i_a=I_arm_mA,omega=speed_rpm", "--units", "omega=furlong"],
            "unknown unit 'furlong'",
        ),
        (["fit", "FILE", "--columns", "t=nope"], "no column 'nope' for t"),
        (["fit", "FILE", "--delimiter", "|"], "delimiter must be one of"),
        (["report", "nothing.json"], "no such result file"),
    ],
)
def test_cli_loading_errors_are_one_line(tmp_path, sd1, args, match, capsys, monkeypatch):
    """In this process (`main`, what `python -m dcjax` calls; `test_cli_module_entry_bad_file`
    runs the module as a process)."""
    f = tmp_path / "daq.csv"
    write_daq(f, sd1)
    args = [str(f) if a == "FILE" else a for a in args]
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err and err.count("\n") == 1, err


def test_version(capsys):
    """`dcjax --version` (the command's `entry`, in this process; `python -m dcjax` itself:
    tests/test_identify.py::test_cli_module_entry_bad_file)."""
    from dcjax.cli import entry

    with pytest.raises(SystemExit) as end:
        entry(["--version"])
    assert end.value.code == 0 and capsys.readouterr().out.strip() == f"dcjax {dcjax.__version__}"


def test_saving_a_plot_keeps_the_backend(sd1, tmp_path):
    import matplotlib

    before = matplotlib.get_backend()
    r = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=1, budget=140))
    r.plot(tmp_path / "fit.png")
    assert matplotlib.get_backend() == before and (tmp_path / "fit.png").stat().st_size > 10_000
    from matplotlib.figure import Figure

    ax = Figure().subplots(1, 2)
    assert r.plot(ax=ax) is ax and len(ax[0].lines) == 2


def write_logger(path: Path, rec: Recording, holes: dict[int, int] | None = None):
    """A recording as an ODrive-style logger writes it: `;` ending every line, a units line under
    the header, `nan` or an empty field in some rows (`holes`: row -> column), irregular times."""
    rows = ["time;voltage;current;speed;", "s;V;A;rad/s;"]
    for k in range(len(rec)):
        fields = [repr(float(v)) for v in (rec.t[k], rec.u_a[k], rec.i_a[k], rec.omega[k])]
        if holes and k in holes:
            fields[holes[k]] = "nan" if k % 2 else ""
        rows.append(";".join(fields) + ";")
    path.write_text("\n".join(rows) + "\n")


def test_a_loggers_file_reads_with_flags_and_no_editing(tmp_path, sd1):
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.8, 1.2, len(sd1))) * 1e-4  # irregular sampling
    rec = sd1.replace(t=t)
    write_logger(tmp_path / "step1.csv", rec, holes={40: 2, 41: 3, 300: 2})
    cols = {"t": "time", "u_a": "voltage", "i_a": "current", "omega": "speed"}
    with pytest.raises(
        ValueError, match=r"step1.csv: line 43: i_a is NaN \(a missing or non-finite field; 3 rows in all; drop_nan=True drops such rows\)"
    ):
        load_recording(tmp_path / "step1.csv", columns=cols)
    with pytest.warns(UserWarning, match=rf"step1.csv: dropped 3 of {len(sd1)} rows with NaN/inf \(in i_a, omega\)"):
        got = load_recording(tmp_path / "step1.csv", columns=cols, drop_nan=True)
    keep = np.setdiff1d(np.arange(len(sd1)), [40, 41, 300])
    np.testing.assert_array_equal(got.t, t[keep])
    np.testing.assert_array_equal(got.i_a, sd1.i_a[keep])
    assert got.metadata["source"]["load"]["drop_nan"] is True
    assert [f.check for f in check_recording(got, dcjax.DC())] == ["irregular"]
    write_logger(tmp_path / "by_hand.csv", rec.replace(u_a=np.zeros(len(sd1))))  # moved by hand: no input
    found = check_recording(load_recording(tmp_path / "by_hand.csv", columns=cols), dcjax.DC())
    assert "no-input" in [f.check for f in found]


@pytest.mark.slow
def test_a_loggers_file_fits_through_the_cli(tmp_path, sd1, capsys):
    write_logger(tmp_path / "step1.csv", sd1, holes={40: 2})
    args = ["--columns", "t=time,u_a=voltage,i_a=current,omega=speed", "--drop-nan", "--bounds", "table4", "--runs", "1"]
    assert main(["fit", str(tmp_path / "step1.csv"), *args, "--budget", "1400", "--out", str(tmp_path / "f")]) == 0
    assert f"dropped 1 of {len(sd1)} rows" in capsys.readouterr().err
    assert main(["validate", str(tmp_path / "f" / "result.json"), str(tmp_path / "step1.csv"), "--out", str(tmp_path / "v")]) == 0


def test_row_values_follow_the_field_rules():
    """`read_table`'s one-pass row reading against the field rules written out here: a missing
    field (MISSING, any case) is NaN, any other must be a number (the decimal separator given); a
    row of missing fields only is a row of NaN (a logger's gap between bursts)."""
    from dcjax.io.table import MISSING
    from dcjax.io.table import row_values as _row_values

    def reference(row, decimal):
        out = []
        for f in row:
            if f.lower() in MISSING:
                out.append(float("nan"))
                continue
            try:
                out.append(float(f.replace(decimal, ".") if decimal != "." else f))
            except ValueError:
                return None
        return out

    fields = ["1", "-2.5e3", " ", "", "nan", "NaN", "NA", "n/a", "null", "None", "inf", "-inf", "1,5", "2.5", "x", "1e", "--", "1_000"]
    rng = np.random.default_rng(0)
    for decimal in (".", ","):
        for _ in range(2000):
            row = [fields[k].strip() for k in rng.integers(len(fields), size=rng.integers(1, 4))]
            want, got = reference(row, decimal), _row_values(row, decimal)
            assert (got is None) == (want is None), (row, decimal)
            if want is not None:
                np.testing.assert_array_equal(got, want)


def test_a_time_column_that_dt_or_rate_replace_is_named_where_they_disagree(tmp_path, sd1):
    """`dt`/`rate` replace a file's time column (t = k dt). Where the file has a column `t` whose
    step is not theirs (a rate typed in kHz for Hz, a column in ms), a one-line warning names
    both steps; where they agree, nothing is said. The times are k dt either way."""
    f = tmp_path / "timed.csv"
    f.write_text(
        "t,u_a,i_a,omega\n" + "\n".join(",".join(repr(float(sd1[c][k])) for c in ("t", "u_a", "i_a", "omega")) for k in range(len(sd1)))
    )
    with pytest.warns(UserWarning, match=r"timed\.csv: dt/rate give 0\.001 s between samples where the file's column 't' steps 0\.0001 s"):
        rec = load_recording(f, rate=1000)
    np.testing.assert_array_equal(rec.t, np.arange(len(sd1)) * 1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.allclose(load_recording(f, dt=1e-4).t, sd1.t, rtol=0, atol=1e-15)
        load_recording(f, rate=10_000.0)
