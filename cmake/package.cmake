# Install rules and Debian packages (issue 32).
#
#   cmake --install build/release --prefix DIR     the layout below under DIR (any prefix)
#   bash scripts/package.sh [amd64|arm64]          edgefusion_<version>_<arch>.deb (CPack's DEB generator)
#
# Layout (prefix /usr, as in the packages):
#   bin/edgefusion
#   share/edgefusion/models/        the shipped models, their cards and the Python model tools (the
#                                   program finds this folder from its own location:
#                                   pipeline/model_paths.h)
#   share/doc/edgefusion/           README.md, copyright (ours and the models' attributions),
#                                   changelog.gz, examples/edgefusion-arm64.yaml
#   /etc/edgefusion/edgefusion.yaml the service's configuration (a conffile: an upgrade keeps the
#                                   board's edits)
#   /lib/systemd/system/edgefusion.service, /lib/udev/rules.d/60-edgefusion-gpio.rules
# With a prefix other than /usr the last three go below the prefix (etc/, lib/), so that an install
# into a folder writes nothing outside it.

install(TARGETS edgefusion RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}")

set(ef_models_dest "${CMAKE_INSTALL_DATADIR}/edgefusion/models")
install(FILES models/deeplabv3-mnv2-nyu13.efm models/edgefusion-seg.efm models/MODEL_CARD.md
              models/MODEL_CARD-deeplab.md models/README.md
        DESTINATION "${ef_models_dest}")
# `edgefusion model import` runs these with PYTHONPATH = the models folder.
install(DIRECTORY models/edgefusion_models DESTINATION "${ef_models_dest}"
        FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)

set(ef_doc_dest "${CMAKE_INSTALL_DATADIR}/doc/edgefusion")
install(FILES README.md firmware_app/package/copyright DESTINATION "${ef_doc_dest}")
install(FILES firmware_app/config/edgefusion-arm64.yaml DESTINATION "${ef_doc_dest}/examples")

if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(ef_etc_dest "/etc/edgefusion")
  set(ef_unit_dest "/lib/systemd/system")  # Debian 12 keeps units of packages in /lib
  set(ef_udev_dest "/lib/udev/rules.d")
else()
  set(ef_etc_dest "${CMAKE_INSTALL_SYSCONFDIR}/edgefusion")
  set(ef_unit_dest "lib/systemd/system")
  set(ef_udev_dest "lib/udev/rules.d")
endif()
install(FILES firmware_app/config/edgefusion-arm64.yaml DESTINATION "${ef_etc_dest}" RENAME edgefusion.yaml)
install(FILES firmware_app/systemd/edgefusion.service DESTINATION "${ef_unit_dest}")
install(FILES firmware_app/package/60-edgefusion-gpio.rules DESTINATION "${ef_udev_dest}")

# Who builds the package: set EF_PACKAGE_MAINTAINER to your team's name and address (the default's
# .invalid domain is RFC 2606's "no such address").
set(EF_PACKAGE_MAINTAINER "EdgeFusion developers <maintainers@edgefusion.invalid>" CACHE STRING
    "Maintainer field of the .deb packages")

# The Debian changelog of a package built from git: one entry naming the version (Debian wants it
# compressed with gzip -9n, no time stamp, in share/doc/<package>).
string(TIMESTAMP ef_changelog_date "%a, %d %b %Y %H:%M:%S +0000" UTC)
set(ef_pkg_dir "${CMAKE_BINARY_DIR}/package")
file(MAKE_DIRECTORY "${ef_pkg_dir}")
file(WRITE "${ef_pkg_dir}/changelog"
     "edgefusion (${EF_VERSION}) unstable; urgency=medium\n\n"
     "  * Built from git (git describe: ${EF_VERSION}).\n\n"
     " -- ${EF_PACKAGE_MAINTAINER}  ${ef_changelog_date}\n")
find_program(EF_GZIP gzip)
if(EF_GZIP)
  execute_process(COMMAND "${EF_GZIP}" -9nf "${ef_pkg_dir}/changelog")
  install(FILES "${ef_pkg_dir}/changelog.gz" DESTINATION "${ef_doc_dest}")
endif()

# ---- CPack: one binary package, edgefusion_<version>_<arch>.deb ----
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME edgefusion)
set(CPACK_PACKAGE_VERSION "${EF_VERSION}")
set(CPACK_PACKAGE_CONTACT "${EF_PACKAGE_MAINTAINER}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "dense 3D semantic mapping for robots on the CPU")
# Lines under 80 characters (Debian's control file rule).
set(CPACK_PACKAGE_DESCRIPTION
    "EdgeFusion maps a room in 3D from a depth camera and labels the map\n"
    "with 13 object classes (SemanticFusion on surfels): camera tracking,\n"
    "surfel fusion, relocalisation and loop closure, an int8 segmentation\n"
    "network and per-surfel label fusion, on the CPU of an ARM board.\n"
    "Includes the systemd service that maps from the robot's camera and\n"
    "continues an interrupted map after a power cut.")
set(CPACK_PACKAGE_FILE_NAME "edgefusion_${EF_VERSION}")  # the architecture is appended below
set(CPACK_PACKAGING_INSTALL_PREFIX "${CMAKE_INSTALL_PREFIX}")
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
# The package's architecture: the target's, not the build machine's (a cross build gives arm64).
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64)$")
  set(ef_deb_arch arm64)
elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
  set(ef_deb_arch amd64)
else()
  set(ef_deb_arch "${CMAKE_SYSTEM_PROCESSOR}")
endif()
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE "${ef_deb_arch}")
set(CPACK_DEBIAN_FILE_NAME "edgefusion_${EF_VERSION}_${ef_deb_arch}.deb")
# Run-time dependencies from the linked libraries (dpkg-shlibdeps; scripts/package.sh points it at
# the arm64 multiarch libraries for the cross build), plus what the maintainer scripts use.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser")
# `edgefusion model import` (Python, optional on a board).
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "python3, python3-numpy, python3-onnx")
configure_file(firmware_app/package/postinst "${ef_pkg_dir}/control/postinst" COPYONLY
               FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  file(WRITE "${ef_pkg_dir}/control/conffiles" "/etc/edgefusion/edgefusion.yaml\n")
  set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA "${ef_pkg_dir}/control/postinst;${ef_pkg_dir}/control/conffiles")
else()
  set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA "${ef_pkg_dir}/control/postinst")
endif()
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
