"""The Linux backends of the ports: python-can, pyserial, smbus2 / IIO, sysfs PWM, libgpiod.

One module per capability and technology. Each opens its device with a message a user can act on
(HardwareError), never blocks the control loop, and de-energises its outputs on `close()`, which
may be called more than once. `bywire.hal.opening.open_hardware` puts them together.
"""
