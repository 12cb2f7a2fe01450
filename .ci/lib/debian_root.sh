# shellcheck shell=bash
# A minimal Debian 12 root for checks that must start from nothing. Sourced, not run: by
# .ci/fresh, and by whatever builds a base container image (`tar -C ROOT -c . | docker import`).
#
#   debian_root_tarball          prints the cached minbase bookworm tarball, making it first
#   debian_root_unpack TAR DIR   a fresh copy of it in DIR (DIR is replaced)
#   debian_root_run DIR CMD      CMD in DIR with a clean environment, in its own mount and PID
#                                namespaces, so nothing it mounts or starts outlives it
#   debian_root_remove DIR       removes DIR, refusing while anything is mounted under it
#
# The root is `debootstrap --variant=minbase bookworm` with the standard main, updates and
# security sources: what a new Debian 12 machine or a debian:12 image starts with, minus even
# the few packages a standard install adds. Needs root. Environment:
#   TERRAIN_CACHE                  cache folder (default ~/.cache/terrain)
#   TERRAIN_DEBIAN_MIRROR          default http://deb.debian.org/debian
#   TERRAIN_DEBIAN_SECURITY_MIRROR default http://deb.debian.org/debian-security

terrain_cache_dir() {
    echo "${TERRAIN_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/terrain}"
}

# Installs host packages the root is made with, when they are missing.
debian_root_host_tools() {
    local missing=() p
    for p in debootstrap debian-archive-keyring; do
        dpkg-query -W -f='${Status}' "$p" 2> /dev/null | grep -q "install ok installed" \
            || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    echo "debian-root: installing ${missing[*]} on this machine" >&2
    DEBIAN_FRONTEND=noninteractive apt-get update -q >&2
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
}

debian_root_tarball() {
    local cache tarball work mirror security
    cache=$(terrain_cache_dir)
    tarball="$cache/bookworm-minbase.tar"
    if [ -s "$tarball" ]; then
        echo "$tarball"
        return 0
    fi
    [ "$(id -u)" -eq 0 ] || {
        echo "debian-root: debootstrap needs root" >&2
        return 1
    }
    debian_root_host_tools || return 1
    mirror="${TERRAIN_DEBIAN_MIRROR:-http://deb.debian.org/debian}"
    security="${TERRAIN_DEBIAN_SECURITY_MIRROR:-http://deb.debian.org/debian-security}"
    mkdir -p "$cache"
    work=$(mktemp -d "$cache/debootstrap.XXXXXX")
    chmod 755 "$work" # it becomes /: _apt and other users must traverse it
    echo "debian-root: debootstrap --variant=minbase bookworm from $mirror (once; cached as $tarball)" >&2
    if ! debootstrap --variant=minbase bookworm "$work" "$mirror" > "$cache/debootstrap.log" 2>&1; then
        tail -n 20 "$cache/debootstrap.log" >&2
        echo "debian-root: debootstrap failed (log: $cache/debootstrap.log)" >&2
        debian_root_remove "$work"
        return 1
    fi
    cat > "$work/etc/apt/sources.list" << EOF
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb $security bookworm-security main
EOF
    rm -f "$work"/var/cache/apt/archives/*.deb
    tar -C "$work" --numeric-owner -cf "$tarball.part" . && mv "$tarball.part" "$tarball"
    debian_root_remove "$work"
    echo "$tarball"
}

# True if anything is mounted at or under $1 (then removing it would reach into the mount).
debian_root_has_mounts() {
    local dir
    dir=$(realpath -m "$1")
    awk -v d="$dir" '$2 == d || index($2, d "/") == 1 { found = 1 } END { exit !found }' /proc/mounts
}

debian_root_remove() {
    [ -e "$1" ] || return 0
    if debian_root_has_mounts "$1"; then
        echo "debian-root: refusing to remove $1: something is still mounted under it" >&2
        return 1
    fi
    rm -rf --one-file-system "$1"
}

debian_root_unpack() {
    local tarball=$1 dir=$2
    debian_root_remove "$dir" || return 1
    mkdir -p "$dir"
    tar -C "$dir" --numeric-owner -xf "$tarball" || return 1
    chmod 755 "$dir"
    cp /etc/resolv.conf "$dir/etc/resolv.conf"
}

# Runs CMD (a bash command line) as root inside DIR. The environment is only HOME, PATH and TERM,
# as at a root login. Downloaded packages are kept in the cache (apt still resolves, verifies and
# installs them), so a second run does not fetch them again.
debian_root_run() {
    local dir archives
    dir=$(realpath "$1")
    archives="$(terrain_cache_dir)/apt-archives"
    mkdir -p "$archives/partial"
    # shellcheck disable=SC2016 # expanded by the inner bash
    unshare --mount --pid --fork --kill-child --propagation private bash -c '
        set -e
        root=$1 archives=$2 command=$3
        mount -t proc proc "$root/proc"
        mount -t sysfs sysfs "$root/sys"
        mount --rbind /dev "$root/dev"
        mount -t tmpfs -o mode=1777 tmpfs "$root/dev/shm"
        mount --bind "$archives" "$root/var/cache/apt/archives"
        exec env -i HOME=/root TERM=dumb \
            PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
            chroot "$root" /bin/bash -c "$command"
    ' debian-root "$dir" "$archives" "$2"
}
