#!/usr/bin/env bash
# Boots the kiosk image under QEMU and checks that the UI comes up and reacts to a touch.
#
#   deploy/test-image.sh [--image deploy/out/volasso.img] [--binary target/release/volasso]
#                       [--accel tcg|kvm] [--gpu virtio|bochs] [--timeout SECONDS]
#
# QEMU and OVMF come from Debian's packages, fetched with `apt-get download` and unpacked with
# `dpkg -x` into deploy/out/qemu (never installed: that would downgrade the host's qemu-utils).
# The image boots with OVMF, a virtio tablet and serial on a file; deploy/qmp_check.py waits for
# `volasso: ready WxH`, takes QMP screendumps before and after a tap (input-send-event), fails
# unless both are non-blank and differ, presses the console's escape keys and checks the UI
# stays, then hot-plugs a USB stick labelled VOLASSO and waits for its volumes to be imported,
# and pushes a DICOM series to the guest's receiver through a forwarded port (user-mode network).
# What a user does by touch (deploy/touch/*.touch: the settings screen through a long press and a
# PIN, two loops on the demo) is compiled on the host by `volasso replay --events-out` (--binary,
# the image's own) at the guest's size and density, and played through the tablet.
# Screenshots and the serial log go to deploy/out/test.
set -euo pipefail
repository=$(cd "$(dirname "$0")/.." && pwd)
deploy="$repository/deploy"
image="$deploy/out/volasso.img"
binary="$repository/target/release/volasso"
accel=tcg
gpu=virtio
timeout_seconds=720
while [ $# -gt 0 ]; do
    case "$1" in
        --image) image=$2; shift 2 ;;
        --binary) binary=$2; shift 2 ;;
        --accel) accel=$2; shift 2 ;;
        --gpu) gpu=$2; shift 2 ;;
        --timeout) timeout_seconds=$2; shift 2 ;;
        -h|--help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "error: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
[ -f "$image" ] || { echo "error: no image at $image: run deploy/build-image.sh first" >&2; exit 1; }
[ -x "$binary" ] || { echo "error: no volasso binary at $binary (--binary): cargo build --release" >&2; exit 1; }

qemu_root="$deploy/out/qemu/root"
qemu="$qemu_root/usr/bin/qemu-system-x86_64"
if [ ! -x "$qemu" ]; then
    echo "=== fetching qemu-system-x86 and OVMF (apt-get download, dpkg -x)"
    # The emulator with its firmware, and the libraries it needs that a Rust host lacks.
    packages=(qemu-system-x86 qemu-system-common qemu-system-data seabios ovmf libaio1 libbpf1 libcapstone4 libfdt1
        libfuse3-3 libibverbs1 libjpeg62-turbo libnuma1 libpixman-1-0 libpmem1 libpng16-16
        librdmacm1 libsasl2-2 libseccomp2 libslirp0 liburing2 libvdeplug2 libndctl6 libdaxctl1
        libnl-3-200 libnl-route-3-200)
    wanted=()
    for package in "${packages[@]}"; do
        case "$package" in
            qemu-*|seabios|ovmf) wanted+=("$package") ;;
            *) dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || wanted+=("$package") ;;
        esac
    done
    downloads="$deploy/out/qemu/debs"
    rm -rf "$downloads" "$qemu_root"
    mkdir -p "$downloads" "$qemu_root"
    apt-get update -qq
    (cd "$downloads" && apt-get download -qq "${wanted[@]}" 2> >(grep -v "unsandboxed as root" >&2))
    for deb in "$downloads"/*.deb; do dpkg -x "$deb" "$qemu_root"; done
fi
# Debian builds TCG and the display devices as loadable modules.
export QEMU_MODULE_DIR="$qemu_root/usr/lib/x86_64-linux-gnu/qemu"
export LD_LIBRARY_PATH="$qemu_root/usr/lib/x86_64-linux-gnu:$qemu_root/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
if ldd "$qemu" | grep -q "not found"; then
    echo "error: qemu-system-x86_64 lacks libraries:" >&2
    ldd "$qemu" | grep "not found" >&2
    exit 1
fi

case "$gpu" in
    virtio) display_device=(-vga none -device virtio-gpu-pci,xres=1280,yres=800) ;;
    bochs) display_device=(-vga none -device bochs-display,xres=1280,yres=800) ;;
    *) echo "error: --gpu is virtio or bochs, not $gpu" >&2; exit 2 ;;
esac
case "$accel" in
    tcg) cpu=(-accel tcg,thread=multi -cpu max) ;;
    kvm) cpu=(-accel kvm -cpu host) ;;
    *) echo "error: --accel is tcg or kvm, not $accel" >&2; exit 2 ;;
esac

results="$deploy/out/test"
rm -rf "$results"
mkdir -p "$results"
# The image stays untouched: the guest writes to a copy-on-write overlay, and to its own copy
# of the UEFI variables.
qemu_img=$(command -v qemu-img || echo "$qemu_root/usr/bin/qemu-img")
"$qemu_img" create -q -f qcow2 -F raw -b "$(realpath "$image")" "$results/overlay.qcow2"
cp "$qemu_root/usr/share/OVMF/OVMF_VARS_4M.fd" "$results/ovmf-vars.fd"
# A USB stick labelled VOLASSO with two small volume files and one file that is not a volume;
# the test hot-plugs it once the UI is up and expects the two to be imported.
stick="$results/stick.img"
command -v mkfs.fat >/dev/null && command -v mcopy >/dev/null \
    || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends dosfstools mtools
mkfs.fat -C -n VOLASSO "$stick" 8192 >/dev/null
printf 'NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n\1\2\3\4\5\6\7\10' > "$results/cube.nrrd"
mmd -i "$stick" ::/volumes
mcopy -i "$stick" "$results/cube.nrrd" ::/cube.nrrd
mcopy -i "$stick" "$results/cube.nrrd" ::/volumes/cube-copy.nrrd
mcopy -i "$stick" "$0" ::/not-a-volume.sh

# The DICOM receiver: QEMU's user-mode network forwards a free host port to the guest's 11112,
# and qmp_check.py pushes the Philips series there with dcmtk's storescu (skipped without it).
network=(-nic none)
dicom=()
series="$repository/../shared/data/dicom/philips_phantom_5mm"
if command -v storescu > /dev/null && [ -d "$series" ]; then
    dicom_port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
    # No option ROM (romfile=): the firmware never boots from the network, and the unpacked
    # packages carry no iPXE ROM for the NIC.
    network=(-netdev "user,id=net0,restrict=on,hostfwd=tcp:127.0.0.1:$dicom_port-:11112"
        -device "virtio-net-pci,netdev=net0,romfile=")
    dicom=(--dicom-port "$dicom_port" --dicom-series "$series")
else
    echo "=== no storescu (apt-get install dcmtk) or no $series: the DICOM push is skipped"
fi

echo "=== image $(realpath "$image"): $(du -h --apparent-size "$image" | cut -f1) ($(stat -c %s "$image") bytes), $gpu display, $accel"
started=$(date +%s.%N)
"$qemu" -name volasso-test -machine q35 "${cpu[@]}" -smp 2 -m 2048 \
    -L "$qemu_root/usr/share/qemu" -L "$qemu_root/usr/share/seabios" \
    -drive if=pflash,format=raw,unit=0,readonly=on,file="$qemu_root/usr/share/OVMF/OVMF_CODE_4M.fd" \
    -drive if=pflash,format=raw,unit=1,file="$results/ovmf-vars.fd" \
    -drive if=virtio,format=qcow2,file="$results/overlay.qcow2" \
    "${display_device[@]}" -device virtio-tablet-pci -device virtio-keyboard-pci \
    -device qemu-xhci,id=xhci -drive if=none,id=stick,format=raw,readonly=on,file="$stick" \
    -display none "${network[@]}" -serial "file:$results/serial.log" \
    -qmp "unix:$results/qmp.sock,server=on,wait=off" -no-reboot &
qemu_pid=$!
trap 'kill "$qemu_pid" 2>/dev/null || true' EXIT
status=0
python3 "$deploy/qmp_check.py" --qemu-pid "$qemu_pid" --qmp "$results/qmp.sock" --stick-volumes 2 --serial "$results/serial.log" \
    --out "$results" --started "$started" --timeout "$timeout_seconds" "${dicom[@]}" \
    --binary "$binary" --touch-dir "$deploy/touch" || status=$?
kill "$qemu_pid" 2>/dev/null || true
wait "$qemu_pid" 2>/dev/null || true
echo "=== serial log: $results/serial.log; screenshots: $results/*.png"
exit "$status"
