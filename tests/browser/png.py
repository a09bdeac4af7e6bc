"""Reads an 8-bit, non-interlaced RGB or RGBA PNG (what Chromium and parrt write) into its width,
height and RGB bytes (row by row, 3 a pixel), with python3's standard library only."""

import struct
import zlib


def read(data):
    """(width, height, RGB bytes) of the PNG `data` (its bytes)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, w, h, bpp = 8, [], 0, 0, 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or interlace != 0 or ctype not in (2, 6):
                raise ValueError("PNG of depth %d, colour type %d, interlace %d: not read here"
                                 % (depth, ctype, interlace))
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + n
    raw, stride = zlib.decompress(b"".join(idat)), w * bpp
    if len(raw) != h * (1 + stride):
        raise ValueError("PNG data of %d bytes for %dx%d" % (len(raw), w, h))
    out, prev = bytearray(), bytearray(stride)
    for y in range(h):
        i = y * (1 + stride)
        f, line = raw[i], bytearray(raw[i + 1:i + 1 + stride])
        if f == 1:
            for x in range(bpp, stride):
                line[x] = (line[x] + line[x - bpp]) & 255
        elif f == 2:
            for x in range(stride):
                line[x] = (line[x] + prev[x]) & 255
        elif f == 3:
            for x in range(stride):
                a = line[x - bpp] if x >= bpp else 0
                line[x] = (line[x] + ((a + prev[x]) >> 1)) & 255
        elif f == 4:
            for x in range(stride):
                if x >= bpp:
                    a, b, c = line[x - bpp], prev[x], prev[x - bpp]
                else:
                    a, b, c = 0, prev[x], 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        elif f != 0:
            raise ValueError("PNG filter %d in row %d" % (f, y))
        out += line if bpp == 3 else bytes(v for k, v in enumerate(line) if k % 4 != 3)
        prev = line
    return w, h, bytes(out)
