#!/usr/bin/env python3
"""Read a GIF's structure and print what an animation test asserts on.

    gif_info.py FILE.gif

Prints one line: `frames N width W height H delays D1,D2,... loop L` (delays in hundredths of a
second from each frame's Graphic Control Extension; loop from the NETSCAPE2.0 extension, -1 when
there is none). Exit 1 with one line when the file is not a well-formed GIF (every block is
walked to the trailer, so a truncated file fails).
"""
import struct
import sys


def skip_sub_blocks(data, i):
    while True:
        if i >= len(data):
            raise ValueError("truncated data sub-blocks")
        n = data[i]
        i += 1
        if n == 0:
            return i
        i += n


def read(data):
    if data[:6] not in (b"GIF87a", b"GIF89a"):
        raise ValueError("not a GIF (no GIF87a / GIF89a signature)")
    width, height, flags = struct.unpack("<HHB", data[6:11])
    i = 13
    if flags & 0x80:
        i += 3 * (2 << (flags & 7))
    frames, delays, loop = 0, [], -1
    while True:
        if i >= len(data):
            raise ValueError("no trailer (truncated)")
        b = data[i]
        if b == 0x3B:
            break
        if b == 0x21:  # extension
            label = data[i + 1]
            if label == 0xF9:
                delays.append(struct.unpack("<H", data[i + 4:i + 6])[0])
            elif label == 0xFF and data[i + 3:i + 14] == b"NETSCAPE2.0":
                loop = struct.unpack("<H", data[i + 16:i + 18])[0]
            i = skip_sub_blocks(data, i + 2)
        elif b == 0x2C:  # image descriptor
            frames += 1
            fl = data[i + 9]
            i += 10
            if fl & 0x80:
                i += 3 * (2 << (fl & 7))
            i = skip_sub_blocks(data, i + 1)  # LZW minimum code size, then the data
        else:
            raise ValueError("unknown block 0x%02x at byte %d" % (b, i))
    return frames, width, height, delays, loop


def main():
    if len(sys.argv) != 2:
        print("usage: gif_info.py FILE.gif")
        return 2
    try:
        with open(sys.argv[1], "rb") as f:
            frames, w, h, delays, loop = read(f.read())
    except (OSError, ValueError, IndexError, struct.error) as e:
        print("gif_info: %s: %s" % (sys.argv[1], e))
        return 1
    print("frames %d width %d height %d delays %s loop %d"
          % (frames, w, h, ",".join(str(d) for d in delays), loop))
    return 0


if __name__ == "__main__":
    sys.exit(main())
