#!/bin/bash
# PID 1 of the kernel tier's user-mode Linux (started by tests/kernel/run, never by hand).
#
# The root file system is the host's, read-only (hostfs): the clone, its .venv and the host's
# tools (ip, tc, candump, insmod) are where they are on the host. Everything the tests write goes
# to tmpfs under /run ($TMPDIR, $HOME): not over /tmp, where the clone or the kernel's cache may
# be (a CI clone in /tmp was hidden by a tmpfs there). Devices are made by the tests themselves
# (tests/kernel/guest.py). pytest's status goes
# to the host over the control line, /dev/ttyS2, then the kernel powers off.
set -u
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mountpoint -q /dev || mount -t devtmpfs devtmpfs /dev
mkdir -p /dev/pts /dev/shm
mount -t devpts devpts /dev/pts
for dir in /dev/shm /run; do mount -t tmpfs tmpfs "$dir"; done
mkdir -p /run/tmp /run/home
mount -t configfs configfs /sys/kernel/config
ip link set lo up
export HOME=/run/home TMPDIR=/run/tmp PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
export BYWIRE_KERNEL_TIER=1 PYTHONDONTWRITEBYTECODE=1 TERM=dumb
cd "$BYWIRE_REPO" || exit 1
# shellcheck disable=SC2086 # the arguments are words on purpose
"$BYWIRE_REPO/.venv/bin/python" -m pytest -p no:cacheprovider ${BYWIRE_PYTEST_ARGS//,/ }
status=$?
echo "exit $status" >/dev/ttyS2
exec "$BYWIRE_REPO/.venv/bin/python" -c 'import ctypes; ctypes.CDLL(None).reboot(0x4321FEDC)'
