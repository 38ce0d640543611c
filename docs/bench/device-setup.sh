# Sourced by the bench scripts on the lent GPU machine (run from the repository root): the
# Vulkan loader from .gl's .deb files and the NVIDIA driver's ICD where the machine lacks its
# own entry.
for deb in .gl/*.deb; do dpkg -x "$deb" /; done
ldconfig
export WGPU_BACKEND=vulkan
if [ ! -e /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
