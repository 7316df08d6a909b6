# Sourced by scripts/container.sh and scripts/standin-base.sh: buildah on vfs storage, which needs
# no overlay support from the kernel, in a store of its own (a store keeps the driver it was made with).
if [ -z "${CONTAINERS_STORAGE_CONF:-}" ]; then
    CONTAINERS_STORAGE_CONF="$(mktemp)"
    cat > "$CONTAINERS_STORAGE_CONF" <<CONF
[storage]
driver = "vfs"
graphroot = "${KFIO_BUILDAH_ROOT:-/var/lib/containers/vfs-storage}"
runroot = "${KFIO_BUILDAH_RUNROOT:-/run/containers/vfs-storage}"
CONF
    export CONTAINERS_STORAGE_CONF
fi
