#!/usr/bin/env bash
# Builds the volasso kiosk appliance: a bootable x86_64 GPT disk image made only from Debian
# bookworm's packages and the volasso release binary (deploy/README.md describes the image).
#
#   deploy/build-image.sh [--out deploy/out/volasso.img] [--binary PATH] [--volume FILE]...
#
# Without --binary it runs `cargo build --release` first. --volume copies a volume file into the
# data partition's volumes folder (repeatable). Missing host tools are installed with apt-get.
# Reproducible by construction: a pinned suite, SOURCE_DATE_EPOCH from the last commit, fixed
# UUIDs and file-system seeds, clamped timestamps; runs as root (mmdebstrap's root mode).
set -euo pipefail
repository=$(cd "$(dirname "$0")/.." && pwd)
deploy="$repository/deploy"
out="$deploy/out/volasso.img"
binary=""
volumes=()
while [ $# -gt 0 ]; do
    case "$1" in
        --out) out=$2; shift 2 ;;
        --binary) binary=$2; shift 2 ;;
        --volume) volumes+=("$2"); shift 2 ;;
        -h|--help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "error: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
started=$(date +%s)
stage() { echo "=== $* ($(( $(date +%s) - started )) s)"; }

suite=bookworm
mirror=http://deb.debian.org/debian
# Fixed identities, so two builds give the same bytes and the boot entry can name its root.
disk_guid=6f6c6173-736f-4000-8000-000000000000
esp_partuuid=6f6c6173-736f-4000-8000-000000000001
root_partuuid=6f6c6173-736f-4000-8000-000000000002
data_partuuid=6f6c6173-736f-4000-8000-000000000003
root_fs_uuid=6f6c6173-736f-4000-8000-000000000012
data_fs_uuid=6f6c6173-736f-4000-8000-000000000013
esp_volume_id=766f6c61
data_size_mib=256
esp_size_mib=96
# The kiosk user's ids are fixed so the data partition's ownership matches the root image.
kiosk_uid=900

[ "$(id -u)" -eq 0 ] || { echo "error: build-image.sh runs as root (mmdebstrap root mode, mkfs -d ownership)" >&2; exit 1; }

host_tools=(mmdebstrap:mmdebstrap mkfs.erofs:erofs-utils mkfs.ext4:e2fsprogs mkfs.fat:dosfstools
    mcopy:mtools sfdisk:fdisk)
missing=()
for entry in "${host_tools[@]}"; do
    command -v "${entry%%:*}" >/dev/null || missing+=("${entry#*:}")
done
if [ ${#missing[@]} -gt 0 ]; then
    stage "apt-get install ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

export SOURCE_DATE_EPOCH=${SOURCE_DATE_EPOCH:-$(git -C "$repository" log -1 --format=%ct 2>/dev/null || echo 1700000000)}
# e2fsprogs takes its clock from here; everything else honours SOURCE_DATE_EPOCH.
export E2FSPROGS_FAKE_TIME=$SOURCE_DATE_EPOCH
export LC_ALL=C.UTF-8 TZ=UTC

if [ -z "$binary" ]; then
    stage "cargo build --release"
    (cd "$repository" && cargo build --release --locked --bin volasso)
    binary="${CARGO_TARGET_DIR:-$repository/target}/release/volasso"
fi
[ -x "$binary" ] || { echo "error: the volasso binary is missing or not executable: $binary" >&2; exit 1; }

work="$deploy/out/work"
rm -rf "$work"
mkdir -p "$work" "$(dirname "$out")"
root="$work/root"

# Packages: systemd and the kernel to boot; Mesa's Vulkan drivers (radv/anv for a real GPU,
# lavapipe as the fallback) and GL/GBM for wgpu; fontconfig and fonts for Slint's text layout; kbd to
# load the keymap that removes console switching; e2fsprogs to check the data partition; nftables
# for the firewall that opens the DICOM receiver's port only.
packages=(systemd systemd-sysv udev kmod linux-image-amd64 initramfs-tools zstd systemd-boot-efi
    mesa-vulkan-drivers libvulkan1 libgl1-mesa-dri libegl1 libegl-mesa0 libgbm1
    libfontconfig1 libfreetype6 fonts-dejavu-core fontconfig-config kbd e2fsprogs dosfstools exfatprogs
    nftables)
include=$(IFS=,; echo "${packages[*]}")

stage "mmdebstrap $suite (root file system)"
mmdebstrap --variant=minbase --mode=root --include="$include" \
    --aptopt='APT::Install-Recommends "false"' \
    --dpkgopt='path-exclude=/usr/share/man/*' --dpkgopt='path-exclude=/usr/share/doc/*' \
    --dpkgopt='path-include=/usr/share/doc/*/copyright' \
    --dpkgopt='path-exclude=/usr/share/locale/*' --dpkgopt='path-exclude=/usr/share/info/*' \
    --essential-hook='mkdir -p "$1/usr/share/initramfs-tools/modules.d" && printf "erofs\nvirtio_pci\nvirtio_blk\nnvme\nahci\nsd_mod\n" > "$1/usr/share/initramfs-tools/modules.d/volasso"' \
    --customize-hook="\"$deploy/customize-root.sh\" \"\$1\" \"$binary\" $kiosk_uid" \
    "$suite" "$root" "$mirror" > "$work/mmdebstrap.log" 2>&1 \
    || { tail -40 "$work/mmdebstrap.log" >&2; exit 1; }

stage "boot partition (systemd-boot, kernel, initramfs)"
kernel=$(cd "$root/boot" && ls vmlinuz-* | sort -V | tail -1)
initrd="initrd.img-${kernel#vmlinuz-}"
esp="$work/esp"
mkdir -p "$esp/EFI/BOOT" "$esp/loader/entries"
cp "$root/usr/lib/systemd/boot/efi/systemd-bootx64.efi" "$esp/EFI/BOOT/BOOTX64.EFI"
cp "$root/boot/$kernel" "$esp/vmlinuz"
cp "$root/boot/$initrd" "$esp/initrd.img"
# editor no: nobody at the kiosk may edit the kernel command line (init=/bin/sh).
printf 'default volasso.conf\ntimeout 0\neditor no\nauto-entries no\nauto-firmware no\n' > "$esp/loader/loader.conf"
cat > "$esp/loader/entries/volasso.conf" <<ENTRY
title volasso kiosk
linux /vmlinuz
initrd /initrd.img
options root=PARTUUID=$root_partuuid rootfstype=erofs ro console=ttyS0,115200 loglevel=4 panic=10 systemd.gpt_auto=0 vt.global_cursor_default=0 systemd.show_status=auto
ENTRY
rm -rf "$root/boot"/* "$root/usr/lib/systemd/boot"
esp_image="$work/esp.img"
mkfs.fat -C -F 32 -n VOLASSO-ESP -i "$esp_volume_id" --invariant "$esp_image" $((esp_size_mib * 1024)) >/dev/null
find "$esp" -exec touch --no-dereference -d "@$SOURCE_DATE_EPOCH" {} +
(cd "$esp" && find . -mindepth 1 -type d | sort | sed 's|^\./||' | while read -r d; do mmd -i "$esp_image" "::/$d"; done
 find . -type f | sort | sed 's|^\./||' | while read -r f; do mcopy -m -i "$esp_image" "$f" "::/$f"; done)

stage "root file system (erofs, read-only)"
find "$root" -newermt "@$SOURCE_DATE_EPOCH" -exec touch --no-dereference -d "@$SOURCE_DATE_EPOCH" {} +
root_image="$work/root.img"
mkfs.erofs -zlz4hc -U "$root_fs_uuid" -T "$SOURCE_DATE_EPOCH" --ignore-mtime \
    "$root_image" "$root" > "$work/mkfs-erofs.log"

stage "data partition (ext4: volumes, sessions, cache)"
data="$work/data"
mkdir -p "$data/volumes" "$data/sessions" "$data/cache"
for volume in "${volumes[@]}"; do cp -- "$volume" "$data/volumes/"; done
chown -R "$kiosk_uid:$kiosk_uid" "$data/volumes" "$data/sessions" "$data/cache"
chmod 0750 "$data/sessions" "$data/cache"
# Shared with the DICOM receiver (group volasso): setgid, group-writable (tmpfiles.d/volasso.conf).
chmod 2770 "$data/volumes"
find "$data" -exec touch --no-dereference -d "@$SOURCE_DATE_EPOCH" {} +
data_image="$work/data.img"
mkfs.ext4 -q -F -L volasso-data -U "$data_fs_uuid" -E "hash_seed=$data_fs_uuid,root_owner=0:0" \
    -d "$data" "$data_image" "${data_size_mib}M"
# mkfs copies each file's ctime, which no tool can set on the source; stamp them afterwards.
stamp=$(date -u -d "@$SOURCE_DATE_EPOCH" +%Y%m%d%H%M%S)
(cd "$data" && find . -mindepth 1 | sort | sed "s|^\.\(.*\)|sif \"\1\" ctime $stamp|") > "$work/data-ctime.debugfs"
debugfs -w -f "$work/data-ctime.debugfs" "$data_image" >/dev/null 2>"$work/debugfs.log" \
    || { cat "$work/debugfs.log" >&2; exit 1; }

stage "disk image (GPT)"
root_size_mib=$(( ($(stat -c %s "$root_image") + 1048575) / 1048576 ))
total_mib=$((1 + esp_size_mib + root_size_mib + data_size_mib + 1))
rm -f "$out"
truncate -s "${total_mib}M" "$out"
sfdisk --quiet --no-reread --no-tell-kernel "$out" <<TABLE
label: gpt
label-id: $disk_guid
first-lba: 2048
start=1MiB, size=${esp_size_mib}MiB, type=uefi, uuid=$esp_partuuid, name=volasso-esp
size=${root_size_mib}MiB, type=4f68bce3-e8cd-4db1-96e7-fbcaf984b709, uuid=$root_partuuid, name=volasso-root
size=${data_size_mib}MiB, type=linux, uuid=$data_partuuid, name=volasso-data
TABLE
offset=1
for part in "$esp_image:$esp_size_mib" "$root_image:$root_size_mib" "$data_image:$data_size_mib"; do
    dd if="${part%%:*}" of="$out" bs=1M seek="$offset" conv=notrunc,sparse status=none
    offset=$((offset + ${part##*:}))
done
stage "done: $out ($(du -h --apparent-size "$out" | cut -f1), sha256 $(sha256sum "$out" | cut -c1-16))"
