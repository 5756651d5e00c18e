#!/usr/bin/env python3
"""Writes the hand-made bad-input corpus of tests/data/bad/ (issue 9).

Every file is assembled byte by byte here (no imaging library), so each defect is exactly
the one named: a file is a valid minimal EXR / PNG / TIFF / JPEG with one thing broken.
The expected outcome of each file (error kind + message substring) is in manifest.tsv,
checked by tests/robustness/bad_corpus_test.cpp. Re-run after editing:
    python3 tests/data/bad/make_bad_corpus.py
"""
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))

# --- OpenEXR (scanline, uncompressed) ------------------------------------------------------
# Layout: magic 76 2f 31 01, version 2, header attributes (name\0 type\0 int32 size, value),
# a terminating \0, one uint64 offset per scanline, then chunks (int32 y, int32 size, the
# channels in alphabetical order, each `width` samples).
HALF, FLOAT = 1, 2


def attr(name, typ, payload):
    return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(payload)) + payload


def exr_head(chl, compression, dw):
    """Magic, version 2 and a scanline header with the required attributes."""
    hdr = b"".join([
        attr("channels", "chlist", chl),
        attr("compression", "compression", bytes([compression])),
        attr("dataWindow", "box2i", struct.pack("<4i", *dw)),
        attr("displayWindow", "box2i", struct.pack("<4i", *dw)),
        attr("lineOrder", "lineOrder", b"\0"),
        attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0)),
        attr("screenWindowWidth", "float", struct.pack("<f", 1.0)),
    ]) + b"\0"
    return b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + hdr


def exr(width, height, channels, pixel, ptype=FLOAT, data_window=None, chlist_override=None):
    """channels: names; pixel(name, x, y) -> float."""
    names = sorted(channels)
    if chlist_override is not None:
        chl = chlist_override
    else:
        chl = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", ptype, 0, 1, 1) for n in names) + b"\0"
    head = exr_head(chl, 0, data_window or (0, 0, width - 1, height - 1))
    fmt = "<e" if ptype == HALF else "<f"
    chunks = []
    for y in range(height):
        body = b"".join(struct.pack(fmt, pixel(n, x, y)) for n in names for x in range(width))
        chunks.append(struct.pack("<ii", y, len(body)) + body)
    table_size = 8 * height
    offsets, pos = [], len(head) + table_size
    for c in chunks:
        offsets.append(pos)
        pos += len(c)
    return head + b"".join(struct.pack("<Q", o) for o in offsets) + b"".join(chunks)


def huge_exr(width, height, compression=4, lines=32):
    """Header + offset table only; PIZ compression (4, 32 scanlines per chunk) by default."""
    chl = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", HALF, 0, 1, 1) for n in "BGR") + b"\0"
    head = exr_head(chl, compression, (0, 0, width - 1, height - 1))
    n = (height + lines - 1) // lines
    end = len(head) + 8 * n
    return head + b"".join(struct.pack("<Q", end) for _ in range(n))


def rgba_pixel(n, x, y):
    return {"R": 0.1 * x, "G": 0.1 * y, "B": 0.5, "A": 1.0}[n]


# --- PNG ---------------------------------------------------------------------------------
def chunk(typ, data):
    return struct.pack(">I", len(data)) + typ + data + struct.pack(">I", zlib.crc32(typ + data) & 0xFFFFFFFF)


def png(width, height, colour_type=2, rows=None, ihdr_size=None, bad_crc=False):
    """8-bit PNG; colour_type 0 grey, 2 RGB, 6 RGBA."""
    spp = {0: 1, 2: 3, 6: 4}[colour_type]
    iw, ih = ihdr_size or (width, height)
    ihdr = struct.pack(">IIBBBBB", iw, ih, 8, colour_type, 0, 0, 0)
    raw = b"".join(b"\0" + bytes(((x * 37 + y * 11 + c * 70) & 0xFF) for x in range(width) for c in range(spp))
                   for y in range(height)) if rows is None else rows
    ih_chunk = chunk(b"IHDR", ihdr)
    if bad_crc:
        ih_chunk = ih_chunk[:-4] + bytes(b ^ 0xFF for b in ih_chunk[-4:])
    return b"\x89PNG\r\n\x1a\n" + ih_chunk + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


# --- TIFF (little-endian, one strip, uncompressed) ----------------------------------------
SHORT, LONG = 3, 4


def tiff(width, height, spp=3, bits=8, declared=None, strip_offset=None, strip_bytes=None, pixels=None,
         compression=1):
    dw, dh = declared or (width, height)
    data = pixels if pixels is not None else bytes((i * 13) & 0xFF for i in range(width * height * spp * bits // 8))
    entries_n = 10
    ifd_off = 8
    ifd_size = 2 + 12 * entries_n + 4
    bps_off = ifd_off + ifd_size
    extra = struct.pack("<" + "H" * spp, *([bits] * spp)) if spp > 2 else b""
    data_off = bps_off + len(extra)
    so = data_off if strip_offset is None else strip_offset
    sb = len(data) if strip_bytes is None else strip_bytes

    def e(tag, typ, count, value):
        if typ == SHORT and count == 1:
            return struct.pack("<HHIHH", tag, typ, count, value, 0)
        return struct.pack("<HHII", tag, typ, count, value)

    bps = e(258, SHORT, spp, bps_off) if spp > 2 else (
        struct.pack("<HHIHH", 258, SHORT, spp, bits, bits if spp == 2 else 0))
    ents = [
        e(256, LONG, 1, dw), e(257, LONG, 1, dh), bps, e(259, SHORT, 1, compression),
        e(262, SHORT, 1, 2 if spp >= 3 else 1), e(273, LONG, 1, so), e(277, SHORT, 1, spp),
        e(278, LONG, 1, dh), e(279, LONG, 1, sb), e(284, SHORT, 1, 1),
    ]
    assert len(ents) == entries_n
    ifd = struct.pack("<H", entries_n) + b"".join(ents) + struct.pack("<I", 0)
    return b"II*\0" + struct.pack("<I", ifd_off) + ifd + extra + data


# --- BigTIFF (little-endian, one strip) ---------------------------------------------------
# Header "II+\0", uint16 8 (offset size), uint16 0, uint64 offset of the first IFD; an IFD is
# a uint64 entry count, 20-byte entries (tag, type, uint64 count, 8-byte value) and a uint64
# next offset.
LONG8 = 16


def bigtiff(width, height, data, declared=None, compression=1, strip_offset=None):
    dw, dh = declared or (width, height)
    ents = [(256, LONG, dw), (257, LONG, dh), (258, SHORT, 8), (259, SHORT, compression), (262, SHORT, 1),
            (273, LONG8, None), (277, SHORT, 1), (278, LONG, dh), (279, LONG8, len(data))]
    ifd_off = 16
    data_off = ifd_off + 8 + 20 * len(ents) + 8
    out = b"II+\0" + struct.pack("<HHQ", 8, 0, ifd_off) + struct.pack("<Q", len(ents))
    for tag, typ, value in ents:
        if value is None:
            value = data_off if strip_offset is None else strip_offset
        out += struct.pack("<HHQQ", tag, typ, 1, value)
    return out + struct.pack("<Q", 0) + data


# --- JPEG (baseline or other frames, hand-made tables) --------------------------------------
# SOI, APP0, a quantisation table, a frame header, Huffman tables of one 1-bit code each (DC
# category 0, AC end-of-block: every 8x8 block costs 2 bits), one scan of `data`, EOI.
def jpeg(width, height, data, comps=3, sof=0xC0, eoi=True):
    out = b"\xff\xd8" + b"\xff\xe0" + struct.pack(">H", 16) + b"JFIF\0\x01\x01\0\0\x01\0\x01\0\0"
    out += b"\xff\xdb" + struct.pack(">H", 67) + b"\0" + bytes(range(1, 65))
    out += bytes([0xFF, sof]) + struct.pack(">HBHHB", 8 + 3 * comps, 8, height, width, comps)
    out += b"".join(bytes([i + 1, 0x11, 0]) for i in range(comps))
    one_code = bytes([1] + [0] * 15) + b"\0"
    out += b"\xff\xc4" + struct.pack(">H", 2 + 2 * 17 + 2) + b"\x00" + one_code + b"\x10" + one_code
    out += b"\xff\xda" + struct.pack(">HB", 6 + 2 * comps, comps) + b"".join(bytes([i + 1, 0]) for i in range(comps))
    out += b"\x00\x3f\x00" + data
    return out + (b"\xff\xd9" if eoi else b"")


# --- deep EXR (scanline, header and chunk table only) --------------------------------------
def deep_exr(dw, display, chunks):
    """chunks: (packed table size, packed sample size, unpacked sample size) per chunk (ZIPS:
    one scanline each); their data are zero bytes of the packed sizes."""
    chl = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", FLOAT, 0, 1, 1) for n in "AZ") + b"\0"
    hdr = b"".join([
        attr("channels", "chlist", chl),
        attr("chunkCount", "int", struct.pack("<i", len(chunks))),
        attr("compression", "compression", bytes([2])),
        attr("dataWindow", "box2i", struct.pack("<4i", *dw)),
        attr("displayWindow", "box2i", struct.pack("<4i", *display)),
        attr("lineOrder", "lineOrder", b"\0"),
        attr("maxSamplesPerPixel", "int", struct.pack("<i", 4)),
        attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0)),
        attr("screenWindowWidth", "float", struct.pack("<f", 1.0)),
        attr("type", "string", b"deepscanline"),
        attr("version", "int", struct.pack("<i", 1)),
    ]) + b"\0"
    head = b"\x76\x2f\x31\x01" + struct.pack("<i", 2 | 0x800) + hdr
    pos = len(head) + 8 * len(chunks)
    table, body = b"", b""
    for y, (t, p, u) in enumerate(chunks):
        table += struct.pack("<Q", pos)
        c = struct.pack("<iQQQ", dw[1] + y, t, p, u) + b"\0" * (t + p)
        body += c
        pos += len(c)
    return head + table + body


# --- the corpus ----------------------------------------------------------------------------
def main():
    files = {}
    good_exr = exr(16, 16, ["R", "G", "B", "A"], rgba_pixel)
    good_png = png(16, 16, 6)
    files["truncated.exr"] = good_exr[: len(good_exr) // 2]
    files["truncated_header.exr"] = good_exr[:40]
    files["truncated.png"] = good_png[: len(good_png) // 2]
    files["truncated_idat.png"] = good_png[: 8 + 25 + 20]
    files["wrong_magic.exr"] = b"\x76\x2f\x31\x02" + good_exr[4:]
    files["wrong_magic.png"] = b"\x89PNx\r\n\x1a\n" + good_png[8:]
    files["empty.exr"] = b""
    files["text.png"] = b"this is a text file, not an image\n" * 4
    files["png_bad_ihdr_crc.png"] = png(4, 4, 2, bad_crc=True)
    files["png_zero_width.png"] = png(4, 4, 2, ihdr_size=(0, 4))
    # Huge declared sizes in tiny files: must be refused from the header, before allocation.
    files["huge.png"] = png(4, 4, 2, ihdr_size=(40000, 40000))
    files["huge.exr"] = exr(2, 2, ["R", "G", "B"], rgba_pixel)
    files["huge.exr"] = files["huge.exr"].replace(struct.pack("<4i", 0, 0, 1, 1), struct.pack("<4i", 0, 0, 99999, 99999))
    # A 20000 x 20000 PIZ-compressed EXR header (4e8 > 2^28 pixels) with a valid offset table and
    # no pixel data: OpenEXR opens it, so only dofkit's pixel budget stands between a 5 KB file
    # and a 6.4 GB float buffer.
    files["huge_declared.exr"] = huge_exr(20000, 20000)
    # Within the pixel budget, but more pixels than the file could hold even at deflate's
    # largest ratio (1032:1): refused before the pixels are allocated. The fuzzer's case: a
    # 2,000,000 x 60 PNG (libpng, so OpenImageIO, refuses widths over 10^6) whose 13-byte
    # zlib stream made the loader allocate 1.3 GB before it failed to inflate.
    files["png_too_short.png"] = png(1, 1, 0, rows=b"\0" * 100, ihdr_size=(2000000, 60))
    files["zip_too_short.exr"] = huge_exr(8000, 8000, compression=3, lines=16)
    files["huge.tif"] = tiff(2, 2, declared=(1000000, 1000000))
    files["huge_wide.tif"] = tiff(2, 2, declared=(300000000, 1))
    files["overflow_window.exr"] = exr(2, 2, ["R", "G", "B"], rgba_pixel).replace(
        struct.pack("<4i", 0, 0, 1, 1), struct.pack("<4i", -2147483647, -2147483647, 2147483646, 2147483646))
    # An attribute whose declared size (1.7 GB) is far beyond the file: OpenEXR allocates and
    # zeroes the declared size before it notices (found by the fuzzer: 16 s and 1.7 GB for a
    # 700-byte file under ASan). Refused by dofkit's own header walk before OpenEXR runs.
    files["huge_attribute.exr"] = good_exr.replace(
        attr("lineOrder", "lineOrder", b"\0"), b"lineOrder\0lineOrder\0" + struct.pack("<i", 0x67000013) + b"\0")
    # 1 x 2^27 pixels (within the budget) in a 300-byte file: its scanline offset table alone
    # would be 1 GiB; the table must be in the file, so the header walk refuses it.
    files["tall_no_table.exr"] = exr(1, 1, ["R", "G", "B"], rgba_pixel, data_window=(0, 0, 0, (1 << 27) - 1))
    # A tEXt chunk whose length field claims 754 MB in a 100-byte PNG: libpng allocates the
    # declared length first (found by the fuzzer: 1 GB and 12 s under ASan for a 5x6 PNG).
    p = good_png_small = png(4, 4, 2)
    iend = p.rindex(b"IEND") - 4
    files["huge_text.png"] = p[:iend] + struct.pack(">I", 0x2d000014) + b"tEXtComment\0hello" + p[iend:]
    # Channel counts: no channel at all, and more than the limit (64).
    files["zero_channels.exr"] = exr(2, 2, [], rgba_pixel, chlist_override=b"\0")
    files["zero_channels.tif"] = tiff(2, 2, spp=1).replace(struct.pack("<HHIHH", 277, SHORT, 1, 1, 0),
                                                          struct.pack("<HHIHH", 277, SHORT, 1, 0, 0))
    many = [f"c{i:02d}" for i in range(65)]
    files["65_channels.exr"] = exr(1, 1, many, lambda n, x, y: 1.0)
    # TIFF whose strip lies beyond the end of the file.
    files["strip_past_eof.tif"] = tiff(4, 4, strip_offset=100000)
    files["truncated_strip.tif"] = tiff(4, 4)[:-28]
    # Empty strip tables (count 0): the fuzzer found the directory walk memcpy'ing from them.
    files["empty_strip_table.tif"] = tiff(4, 4).replace(struct.pack("<HHII", 273, LONG, 1, 8 + 126 + 6),
                                                        struct.pack("<HHII", 273, LONG, 0, 0)).replace(
        struct.pack("<HHII", 279, LONG, 1, 48), struct.pack("<HHII", 279, LONG, 0, 0))
    # JPEG that stops right after its start-of-image and a partial APP0 segment.
    # Found by the fuzzer (2026-11-23): an EXR header that OpenEXR's core library (dofkit's
    # direct reader) parses as 5 x 1835012 pixels and its C++ library (OpenImageIO) as 5 x 4; the
    # direct reader cannot decode the chunks, so the file falls back to OpenImageIO, and the
    # buffers sized from the first header overflowed. Kept byte for byte.
    files["readers_disagree.exr"] = bytes.fromhex(
        "762f3101020000006361704461746500737472696e670013000000323032363a31313a32322030333a34313a35386368"
        "616e6e656c730063686c697374001300000059000100000000000000010000000100000000636f6d7072657373696f6e"
        "00636f6d7072657373696f6e0001000000036461746157696e646f7700626f7832690010000000000000000000000004"
        "00000003001c00646973706c617957696e646f3a32322030333a34313a35386368616e6e656c730063686c6973740013"
        "00000059000100000000000000010000000100000000636f6d70ffff72657373696f6e00636f6d7072657373696f406e"
        "0001000000036461746157696e646f7700626f783269001000000000000000000000000400000003000000646973706c"
        "617957000000000000350000000000000000000000000000000000000000000000000000000000000000000000000000"
        "637265656e57696e646f7743656e7465720076326600000000000000000000000002736372659b91a896919b90805769"
        "64746800666c6f617400040000000000803f0043010000000000000000000028000000007c3241b3449a3f0044cd3c9a"
        "4200383341007c9a3f0044cd3c007c0038696f6e00636f6d70cd3c")
    # Found by the fuzzer in CI (2026-11-23), the same family: dataWindow twice, 6778373 x 20 px
    # then 5 x 4. The header walk and OpenImageIO took the second, the direct reader the first and
    # allocated 2 GB for the colour planes. A repeated attribute name is now refused by the walk.
    files["duplicate_window_wide.exr"] = bytes.fromhex(
        "762f3101020000006361704461746500737472696e670013000000323032363a31313a32322030333a34313a35386368"
        "616e6e656c730063686c697374001300000059000100000000000000010000000100000000636f6d7072657373696f6e"
        "00636f6d7072657373696f6e0001000000036461746157696e646f7700626f7832690010000000000000000000000004"
        "6e670013000000323032363a31313a32322030333a34313a35386368616e6e656c730063686c69737400130000005900"
        "0100000000000000010000000100000000636f6d7072657373696f6e00636f6d7072657373696f6e0001000000036461"
        "746157696e646f7700626f783269001000000000000000000000000400000003000000646973706c0100000000000000"
        "00626f7832690010000000000000000000000004000000030000006c696e654f72646572006c696e654f726465720001"
        "00000000706978656c417370656374526174696f00666c6f617400040000000000803f73637265656e57696e646f7743"
        "656e746572007632660008000000000000000000000073637265656e57696e646f77576964746800666c6f6174000400"
        "00000000803f0043010000000000000000000028000000007c3341b3449a3f0044cd3c9a4200383341007c9a3f0044cd"
        "3c007c00000003000000646973706c010000000000000000626f78326900100000000000000000000000040000000300"
        "00006c696e654f72646572006c696e654f72646572000100000000706978656c417370656374526174696f00666c6f61"
        "7400040000000000803f73637265656e57696e646f7743656e7465720076326600080000000000000000000000736372"
        "65656e57696e646f77576964746800666c6f617400040000000000803f0043010000000000000000000028000000007c"
        "3341b3449a3f0044cd3c9a4200383341007c9a3f0044cd3c007c00383341b344007c0044cd3c")
    files["jpeg_soi_only.jpg"] = b"\xff\xd8\xff\xe0\x00\x10JFIF\x00"
    # Frame-level defects: colour and depth of different sizes, invalid depth values.
    files["color_8x6.exr"] = exr(8, 6, ["R", "G", "B", "A"], rgba_pixel)
    files["depth_8x5.exr"] = exr(8, 5, ["Z"], lambda n, x, y: 2.0)
    files["depth_nan.exr"] = exr(8, 6, ["Z"], lambda n, x, y: math.nan if (x, y) == (2, 1) else 2.0)
    files["depth_negative.exr"] = exr(8, 6, ["Z"], lambda n, x, y: -1.0 if (x, y) == (5, 4) else 2.0)
    files["depth_zero_half.exr"] = exr(8, 6, ["Z"], lambda n, x, y: 0.0 if x == 0 else 2.0, ptype=HALF)
    files["depth_rgb_not_grey.png"] = png(8, 6, 2)
    # A PNG misnamed .exr is still read (OIIO goes by content): not an error.
    files["png_named.exr"] = png(8, 6, 2)
    # --- issue 37: formats and codecs the header walk did not cover -------------------------
    # A 649-byte JPEG declaring 16000 x 16000: 7 GB and 24 s before it failed on the depth's
    # size. Every 8x8 block costs at least 2 bits (DC + end of block): refused by the walk.
    files["jpeg_16000.jpg"] = jpeg(16000, 16000, b"\0" * 480)
    files["jpeg_arithmetic.jpg"] = jpeg(64, 48, b"\0" * 64, sof=0xC9)
    files["jpeg_no_eoi.jpg"] = jpeg(16, 16, b"\0" * 8, eoi=False)
    seed = open(os.path.join(HERE, "..", "..", "..", "fuzz", "corpus", "load_render", "jpeg_rgb"), "rb").read()[8:]
    files["jpeg_truncated.jpg"] = seed[: len(seed) // 2]
    # A 16 KB CCITT-G4 TIFF of 16000 x 16000 (5 GB, 15-19 s): G4 codes a blank row in a bit,
    # so no ratio bounds it; refused by codec. Unknown codes rendered all black.
    files["tiff_g4_16000.tif"] = tiff(128, 128, spp=1, bits=1, declared=(16000, 16000), compression=4)
    files["tiff_compression_34712.tif"] = tiff(4, 4, compression=34712)
    files["tiff_compression_99.tif"] = tiff(4, 4, compression=99)
    # BigTIFF had no header walk: a 1.2 KB file of 16000 x 16000 took 1.2 GB.
    files["bigtiff_16000.tif"] = bigtiff(16, 16, b"\x78\x9c" + b"\0" * 1200, declared=(16000, 16000), compression=8)
    files["bigtiff_huge.tif"] = bigtiff(4, 4, bytes(16), declared=(1000000, 1000000))
    files["bigtiff_strip_past_eof.tif"] = bigtiff(4, 4, bytes(16), strip_offset=1000000)
    files["bigtiff_ok.tif"] = bigtiff(4, 4, bytes(range(0, 160, 10)))
    # PIZ, B44 and DWAA had no bound: 8000 x 8000 half RGB headers with no pixel data.
    files["piz_too_short.exr"] = huge_exr(8000, 8000, compression=4, lines=32)
    files["b44_too_short.exr"] = huge_exr(8000, 8000, compression=6, lines=32)
    files["dwaa_too_short.exr"] = huge_exr(8000, 8000, compression=8, lines=32)
    # Deep EXR: a 2x2 data window in a 32768 x 32768 display window (the frame the layers
    # reader fills: out of memory after 8.9 GB and 40 s), and a chunk whose samples claim 1 TB.
    files["deep_display_huge.exr"] = deep_exr((0, 0, 1, 1), (0, 0, 32767, 32767), [(20, 10, 40), (20, 10, 40)])
    files["deep_samples_lie.exr"] = deep_exr((0, 0, 1, 1), (0, 0, 1, 1), [(20, 10, 10 ** 12), (20, 10, 40)])
    # A palette PNG with a damaged image stream (it went to OpenImageIO, whose libpng printed
    # its own line), and an unknown critical chunk.
    plte = b"\x10\x20\x30\x80\x90\xa0"
    ihdr = struct.pack(">IIBBBBB", 4, 4, 8, 3, 0, 0, 0)
    idat = bytearray(zlib.compress(b"\0\0\1\0\1" * 4))
    idat[4] ^= 0xFF
    files["palette_bad_idat.png"] = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"PLTE", plte) +
                                     chunk(b"IDAT", bytes(idat)) + chunk(b"IEND", b""))
    files["png_unknown_critical.png"] = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"PLTE", plte) +
                                         chunk(b"ABCD", b"x") + chunk(b"IDAT", zlib.compress(b"\0\0\1\0\1" * 4)) +
                                         chunk(b"IEND", b""))
    for name, data in sorted(files.items()):
        with open(os.path.join(HERE, name), "wb") as f:
            f.write(data)
    print(f"wrote {len(files)} files, {sum(len(d) for d in files.values())} bytes")


if __name__ == "__main__":
    main()
