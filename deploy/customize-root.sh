#!/usr/bin/env bash
# mmdebstrap customize hook for build-image.sh: turns the bootstrapped Debian into the kiosk.
#   customize-root.sh ROOT BINARY KIOSK_UID
# Copies deploy/rootfs over ROOT, installs the binary, adds the kiosk and receiver users, enables
# the kiosk and receiver units, masks every way to a login or a console, and strips what a
# read-only appliance never uses.
set -euo pipefail
root=$1
binary=$2
kiosk_uid=$3
deploy=$(cd "$(dirname "$0")" && pwd)

# Fresh timestamps, clamped to SOURCE_DATE_EPOCH later: a checkout's own mtimes vary.
cp -a --no-preserve=ownership,timestamps "$deploy/rootfs/." "$root/"
install -m 0755 "$binary" "$root/usr/bin/volasso"
# The release profile keeps line tables for developers' backtraces (about 140 MB); the
# appliance keeps the symbols (function names in a panic's backtrace) and drops the rest.
strip --strip-debug "$root/usr/bin/volasso"
# A library the binary links but the image lacks would only show as a crash loop at boot.
if chroot "$root" ldd /usr/bin/volasso | grep "not found"; then
    echo "error: /usr/bin/volasso needs libraries the image lacks (above): add their packages to build-image.sh" >&2
    exit 1
fi

# Unprivileged kiosk user: no home, no shell, only the display (video) and touch (input) devices.
chroot "$root" groupadd --system --gid "$kiosk_uid" volasso
chroot "$root" useradd --system --uid "$kiosk_uid" --gid volasso --groups video,input \
    --home-dir /nonexistent --no-create-home --shell /usr/sbin/nologin volasso
# The DICOM receiver's own user (the next uid, fixed like the kiosk's): in the kiosk's group only,
# so that it can add series to the shared volumes folder and nothing else.
chroot "$root" useradd --system --uid "$((kiosk_uid + 1))" --gid volasso \
    --home-dir /nonexistent --no-create-home --shell /usr/sbin/nologin volasso-receive

echo volasso > "$root/etc/hostname"
printf '127.0.0.1 localhost\n127.0.1.1 volasso\n' > "$root/etc/hosts"
# Empty machine-id: systemd makes a transient one at each boot on the read-only root.
: > "$root/etc/machine-id"
mkdir -p "$root/var/lib/volasso"

chroot "$root" systemctl enable volasso.service volasso-keymap.service
# The DICOM receiver, its network (DHCP on Ethernet, systemd-networkd) and the firewall that
# opens its port only (/etc/nftables.conf).
chroot "$root" systemctl enable volasso-receive.service volasso-firewall.service systemd-networkd.service
chroot "$root" systemctl set-default multi-user.target
# No login anywhere (display, serial, container consoles), no Ctrl-Alt-Del reboot, no first-boot
# questions and nothing that wants a writable root.
chroot "$root" systemctl mask getty@.service serial-getty@.service console-getty.service \
    container-getty@.service autovt@.service getty.target ctrl-alt-del.target \
    systemd-firstboot.service systemd-machine-id-commit.service rescue.service emergency.service \
    debug-shell.service apt-daily.timer apt-daily-upgrade.timer e2scrub_all.timer \
    e2scrub_reap.service fstrim.timer systemd-update-utmp.service systemd-update-utmp-runlevel.service

# The root is erofs: drop package caches and logs that would only be frozen in place.
rm -rf "$root"/var/cache/apt/* "$root"/var/lib/apt/lists/* "$root"/var/log/* "$root"/tmp/* \
    "$root"/var/cache/debconf/*-old "$root"/var/lib/dpkg/*-old "$root"/etc/*- "$root"/var/cache/ldconfig/aux-cache

# Kernel modules a kiosk without wireless, sound or cameras never loads. Wired network drivers
# (drivers/net) and the network stack's modules (kernel/net: nftables) stay for the DICOM
# receiver; wireless ones go.
for modules in "$root"/usr/lib/modules/*; do
    rm -rf "$modules"/kernel/drivers/{media,infiniband,staging,comedi,isdn,bluetooth,iio,target,mtd,atm,nfc} \
        "$modules"/kernel/drivers/net/wireless "$modules"/kernel/sound \
        "$modules"/kernel/net/{bluetooth,wireless,mac80211,nfc}
    chroot "$root" depmod "$(basename "$modules")"
done
