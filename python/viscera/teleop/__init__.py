"""Rehearsal: a person drives the tools of a task (viscera.teleop.session), with a keyboard,
a gamepad, a SpaceMouse or an external haptic device on a socket (viscera.teleop.devices),
in MuJoCo's viewer with an overlay (viscera.teleop.app, `python -m viscera teleop`)."""
