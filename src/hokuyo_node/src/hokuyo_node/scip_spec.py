"""Hokuyo SCIP 2.0: the facts of the specification, as data.

Source: Hokuyo "Communication Protocol Specification for SCIP2.0 Standard"
(C-42-03320B) and the URG-04LX specification. Constants only; the driver's
codec (:mod:`hokuyo_node.scip`) and the emulator (:mod:`hokuyo_node.urg_emulator`)
are written separately against them.

Format facts:
- a command is ``symbol(2) parameters [;string(<=16)] LF`` (CR or CR LF also end it);
- a reply is ``echo LF status(2) sum LF [data sum LF]... LF`` (ends in two LF);
- sum = (sum of the bytes of the line before it & 0x3F) + 0x30; for
  ``KEY:value;sum`` information lines the sum covers ``KEY:value``;
- 2-, 3- and 4-character encodings: 6 bits per character, value + 0x30, most
  significant character first;
- measurement data come in blocks of at most 64 characters, each followed by
  its sum and LF; a value may straddle two blocks;
- MD/MS (continuous, 3/2-character data): first reply status "00", then every
  scan with status "99", a 4-character time stamp [ms, 24 bit] and the data;
  GD/GS (one scan): status "00", time stamp, data.
"""

LF = 0x0A
CR = 0x0D
ENCODING_OFFSET = 0x30
BITS_PER_CHAR = 6
BLOCK_SIZE = 64  # [chars] of measurement data per line
TIMESTAMP_CHARS = 4
TIMESTAMP_MODULO = 1 << 24  # [ms] the time stamp wraps after 4.66 h

# Commands.
SCIP2 = b"SCIP2.0"
VERSION = b"VV"
PARAMETERS = b"PP"
STATE = b"II"
LASER_ON = b"BM"
LASER_OFF = b"QT"
RESET = b"RS"
TIME = b"TM"  # TM0 adjust mode on, TM1 read time, TM2 adjust mode off
MEASURE_3 = b"MD"  # continuous, 3-character ranges
MEASURE_2 = b"MS"  # continuous, 2-character ranges
SCAN_3 = b"GD"  # one scan, 3-character ranges
SCAN_2 = b"GS"  # one scan, 2-character ranges
MEASURE_INTENSITY = b"ME"  # continuous, range + intensity (not on the URG-04LX)

DATA_CHARS = {MEASURE_3: 3, MEASURE_2: 2, SCAN_3: 3, SCAN_2: 2}

# Status codes.
STATUS_OK = b"00"
STATUS_SCAN = b"99"  # a scan of a continuous measurement
STATUS_LASER_ALREADY_ON = b"02"  # reply of BM
STATUS_UNDEFINED_COMMAND = b"0E"
MEASUREMENT_STATUS = {
    b"01": "starting step has non-numeric value",
    b"02": "end step has non-numeric value",
    b"03": "cluster count has non-numeric value",
    b"04": "end step is out of range",
    b"05": "end step is smaller than starting step",
    b"06": "scan interval has non-numeric value",
    b"07": "number of scans has non-numeric value",
}

# Information keys.
PP_KEYS = ("MODL", "DMIN", "DMAX", "ARES", "AMIN", "AMAX", "AFRT", "SCAN")
VV_KEYS = ("VEND", "PROD", "FIRM", "PROT", "SERI")
II_KEYS = ("MODL", "LASR", "SCSP", "MESM", "SBPS", "TIME", "STAT")

# URG-04LX (PP answer of the datasheet): ranges below DMIN are error codes, not distances.
URG_04LX = {"MODL": "URG-04LX(Hokuyo Automatic Co.,Ltd.)", "DMIN": 20, "DMAX": 5600, "ARES": 1024,
            "AMIN": 44, "AMAX": 725, "AFRT": 384, "SCAN": 600}

# Models that answer ME (range + intensity). The URG-04LX does not.
INTENSITY_MODELS = ("UTM-30LX", "UTM-30LX-EW", "UST-10LX", "UST-20LX", "UXM-30LX-EW")
