#!/usr/bin/env python3
"""Print flash and RAM use of ARM images from arm-none-eabi-size (Berkeley format).

    arm_usage.py SIZE_TOOL IMAGE.elf...

flash = text + data, RAM = data + bss (settings storage and buffers included;
the stack grows down from the top of RAM and is not counted).
"""
import subprocess
import sys

LIMITS = {"netduinoplus2": (1024 * 1024, 128 * 1024), "nucleo-f446": (512 * 1024, 128 * 1024)}


def main(argv):
    tool, images = argv[1], argv[2:]
    for img in images:
        out = subprocess.run([tool, img], check=True, capture_output=True, text=True).stdout
        text, data, bss = (int(v) for v in out.splitlines()[1].split()[:3])
        name = img.rsplit("/", 1)[-1].removesuffix(".elf")
        flash_max, ram_max = LIMITS.get(name, (0, 0))
        flash, ram = text + data, data + bss
        pct = (lambda a, b: f" ({100.0 * a / b:.1f} % of {b // 1024} KiB)" if b else "")
        print(f"{name}: flash {flash} bytes{pct(flash, flash_max)}, RAM {ram} bytes{pct(ram, ram_max)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
