#!/usr/bin/env bash
# Builds the kernel tier's user-mode Linux kernel and its modules, once, into a cache outside the
# clone; prints the kernel directory on stdout (everything else goes to stderr).
#
# Source: Debian's linux-source-6.1 (apt-get install linux-source-6.1 user-mode-linux bc flex
# bison libelf-dev). The kernel is `make ARCH=um tinyconfig` plus tests/kernel/uml.config, built
# on every core, with the patches of tests/kernel/*.patch; every option of uml.config is checked to
# have survived Kconfig. The cache key is the Debian package's version and the hash of uml.config,
# the patches and this script, so a change or a Debian update builds anew and an unchanged one
# costs nothing. The out-of-tree modules of
# tests/kernel/modules are built against that tree, keyed by the hash of their sources.
#
# Cache: $BYWIRE_KERNEL_CACHE, else $XDG_CACHE_HOME/bywire-kernel, else ~/.cache/bywire-kernel.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
series=6.1 # the kernel series the config and the modules are written for (pinned)
tarball=/usr/src/linux-source-$series.tar.xz
if [[ ! -r $tarball ]]; then
    echo "kernel tier: $tarball missing: apt-get install linux-source-$series user-mode-linux" \
        "bc flex bison libelf-dev" >&2
    exit 2
fi
package_version="$(dpkg-query -W -f='${Version}' "linux-source-$series" 2>/dev/null || echo unknown)"
key="$(cat "$here/uml.config" "$here/build.sh" "$here"/*.patch | sha256sum | cut -c1-12)"
cache="${BYWIRE_KERNEL_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/bywire-kernel}"
kdir="$cache/$series-$package_version-$key"
tree="$kdir/linux-source-$series"
jobs="$(nproc)"

if [[ ! -x $kdir/linux ]]; then
    start=$SECONDS
    rm -rf "$kdir" && mkdir -p "$kdir"
    echo "kernel tier: building the UML kernel ($series, Debian $package_version) in $kdir" >&2
    tar -xf "$tarball" -C "$kdir" --exclude='*/tools/testing' # Kconfig reads every arch/
    echo "kernel tier: extracted in $((SECONDS - start)) s" >&2
    for patch in "$here"/*.patch; do patch -s -d "$tree" -p1 <"$patch"; done
    make -s -C "$tree" ARCH=um tinyconfig >/dev/null
    (cd "$tree" && ARCH=um scripts/kconfig/merge_config.sh -m .config "$here/uml.config" >/dev/null)
    make -s -C "$tree" ARCH=um olddefconfig >&2
    missing=0
    while read -r line; do
        if ! grep -qx "$line" "$tree/.config"; then
            echo "kernel tier: $line did not survive Kconfig (a dependency is missing)" >&2
            missing=1
        fi
    done < <(grep '^CONFIG_' "$here/uml.config")
    [[ $missing == 0 ]] || exit 1
    make -s -C "$tree" ARCH=um -j"$jobs" linux modules >&2
    cp "$tree/linux" "$kdir/linux.tmp" && mv "$kdir/linux.tmp" "$kdir/linux"
    echo "kernel tier: kernel built in $((SECONDS - start)) s" >&2
fi

modules_key="$(cat "$here"/modules/*.c "$here/modules/Makefile" | sha256sum | cut -c1-12)"
mdir="$kdir/modules-$modules_key"
if [[ ! -f $mdir/ready ]]; then
    start=$SECONDS
    rm -rf "$kdir"/modules-* && mkdir -p "$mdir"
    cp "$here"/modules/*.c "$here/modules/Makefile" "$mdir/"
    make -s -C "$tree" ARCH=um M="$mdir" -j"$jobs" modules >&2
    # The tree's own modules the tier loads, beside ours: one directory for insmod.
    for module in drivers/net/can/vcan drivers/net/can/vxcan drivers/i2c/i2c-stub \
        drivers/gpio/gpio-sim drivers/iio/dac/ti-dac5571; do
        cp "$tree/$module.ko" "$mdir/"
    done
    touch "$mdir/ready"
    echo "kernel tier: modules built in $((SECONDS - start)) s" >&2
fi
echo "$kdir"
