"""Rehearsal: a person drives the tools of a task (viscera.teleop.session), with a keyboard,
a gamepad, a SpaceMouse or an external haptic device on a socket (viscera.teleop.devices),
in MuJoCo's viewer with an overlay (viscera.teleop.app, `python -m viscera teleop`)."""


def make(name: str, port: int | None = None, cpu: int | None = None):
    """The device called `name` (one of viscera.teleop.devices.DEVICES); DeviceError when it
    cannot start. Each device's library is imported only when that device is made. `port` and
    `cpu` (the core its server runs on) are the socket device's."""
    from viscera.teleop import devices
    if name == "keyboard":
        return devices.KeyboardDevice()
    if name == "gamepad":
        return devices.GamepadDevice()
    if name == "spacemouse":
        return devices.SpaceMouseDevice()
    if name == "socket":
        from viscera.teleop.socket_device import SocketDevice
        return SocketDevice(**({} if port is None else {"port": port}), cpu=cpu)
    raise devices.DeviceError(f"--device {name!r}: not a device; one of {', '.join(devices.DEVICES)}")
