"""What check_broadcast_wire.py, check_paper_wire.py and check_serve_wire.py share: reading
the configuration a run used (can.drives, can.bus_layout, safety.torque.max) and the frames
of a `candump -l` capture. Standard library only (runs with Debian's /usr/bin/python3 inside
the user-mode-linux guest). The scripts import it from their own folder (tests/hil/).

Every refusal is a SystemExit whose message starts with the calling script's name (`tool`)
and names the file and the key.
"""
import re


def read_config(path):
    """The configuration file's text (the checks read it with regular expressions: the
    guest has no YAML library)."""
    return open(path).read()


def config_drives(text, path, tool):
    """can.drives: [{"node": node_id, "rated": rated_torque (N m), "max": max_torque (N m)}]
    in file order (config/dualv.yaml: one `- {node_id: ..., ...}` flow mapping per drive)."""
    drives = []
    for m in re.finditer(r"-\s*\{([^}]*node_id[^}]*)\}", text):
        fields = dict(re.findall(r"(\w+):\s*([-0-9.eE+]+)", m.group(1)))
        drives.append({
            "node": int(fields["node_id"]),
            "rated": float(fields["rated_torque"]),
            "max": float(fields["max_torque"]),
        })
    if not drives:
        raise SystemExit(f"{tool}: no can.drives entries in {path}")
    return drives


def config_bus_layout(text):
    """can.bus_layout as written, or None when the file does not say (per_drive then)."""
    layout = re.search(r"\n\s+bus_layout:\s*(\w+)", text)
    return layout.group(1) if layout else None


def config_torque_max(text, path, tool):
    """safety.torque.max in N m."""
    at = text.find("\nsafety:")
    torque = re.search(r"\n\s+torque:\s*\n\s+max:\s*([0-9.]+)", text[at:]) if at >= 0 else None
    if not torque:
        raise SystemExit(f"{tool}: no safety.torque.max in {path}")
    return float(torque.group(1))


def frames(path):
    """(time s, COB-ID, data bytes) of every frame line "(t) iface ID#DATA" of `candump -l`."""
    pat = re.compile(r"^\((\d+\.\d+)\)\s+(\S+)\s+([0-9A-Fa-f]+)#([0-9A-Fa-f]*)$")
    for line in open(path):
        m = pat.match(line.strip())
        if m:
            yield float(m.group(1)), int(m.group(3), 16), bytes.fromhex(m.group(4))
