# Debian packages (scripts/package.sh: cpack -G DEB in a build configured with
# NHNET_DEBIAN_PACKAGES=ON and CMAKE_INSTALL_PREFIX=/usr), one per install component, split the
# way Debian splits a project (docs/design/decisions.md#debian-packages):
#   nhnet-models              the shipped NH-Net models, installed once for every front end
#   nhnet-cli                 nhnet-cli
#   python3-nhnet             `import nhnet` for Debian's python3 (/usr/lib/python3/dist-packages)
#   libnhnet-dev              headers, libnhnet.a, the CMake package, the PCL class
#   meshlab-plugin-nhnet      the MeshLab filter, pinned to the MeshLab it was built against
#   cloudcompare-plugin-nhnet the CloudCompare plugin, pinned the same way
# Every package has the project's one version (project(VERSION) of the top CMakeLists.txt).
# A part the build lacks (no MeshLab headers, say) has no files and so no package; scripts/
# package.sh says which were skipped. The copyright file: cmake/debian/copyright.

set(NHNET_DEB_MAINTAINER "nhnet developers <nhnet@packages.invalid>" CACHE STRING
    "Maintainer field of the Debian packages")
set(NHNET_DEB_RELEASE 1 CACHE STRING "Debian revision of the packages (VERSION-RELEASE)")

# The version of an installed Debian package, for the hosts' exact pins.
function(nhnet_deb_installed_version package out)
  execute_process(COMMAND dpkg-query -W -f=\${Version} ${package}
                  OUTPUT_VARIABLE _v RESULT_VARIABLE _rc ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT _rc EQUAL 0)
    set(_v "")
  endif()
  set(${out} "${_v}" PARENT_SCOPE)
endfunction()

# Per package: the copyright file and changelog.Debian.gz Debian policy asks of every binary
# package (/usr/share/doc/PACKAGE/), from the repo's own LICENSE and CHANGELOG.md.
function(nhnet_deb_docs component package)
  set(_doc ${PROJECT_BINARY_DIR}/debian-doc/${package})
  file(MAKE_DIRECTORY ${_doc})
  configure_file(${PROJECT_SOURCE_DIR}/cmake/debian/copyright ${_doc}/copyright COPYONLY)
  string(TIMESTAMP _date "%a, %d %b %Y %H:%M:%S +0000" UTC)
  file(WRITE ${_doc}/changelog.Debian
       "${package} (${PROJECT_VERSION}-${NHNET_DEB_RELEASE}) unstable; urgency=medium\n\n"
       "  * Built from the nhnet source tree; the changes are in CHANGELOG.md upstream.\n\n"
       " -- ${NHNET_DEB_MAINTAINER}  ${_date}\n")
  execute_process(COMMAND gzip -9nf ${_doc}/changelog.Debian)
  install(FILES ${_doc}/copyright ${_doc}/changelog.Debian.gz
          DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/${package} COMPONENT ${component})
endfunction()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME nhnet)
set(CPACK_PACKAGE_VENDOR "nhnet developers")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${NHNET_DEB_MAINTAINER}")
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE ${NHNET_DEB_RELEASE})
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# Debian's torch multiplies matrices through the libblas.so.3 alternative, the reference BLAS
# (~16x slower) unless a faster one is installed: BLIS (docs/design/decisions.md#blis-under-torch).
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "libblis4-openmp")
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS ON)
# The hosts' libraries are private and unversioned (libmeshlab-common.so, libCC_CORE_LIB.so):
# dpkg-shlibdeps finds them here and the host's exact version is pinned by hand below.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS
    ${NHNET_MESHLAB_LIBDIR} ${NHNET_CC_LIBDIR})

set(_summary "normal estimation for unstructured point clouds (NH-Net)")
# The long description: lines under 80 characters, an empty line between paragraphs (cpack
# indents them and writes " ." for the empty ones), no double quotes (cpack's list syntax).
set(_about "nhnet estimates surface normals of raw point clouds (scans, photogrammetry),
noisy ones with sharp edges included, by PCA, multi-scale fitting patch
selection and the NH-Net network of the CVPR 2020 paper Geometry and Learning
Co-supported Normal Estimation for Unstructured Point Cloud.")

set(CPACK_DEBIAN_MODELS_PACKAGE_NAME nhnet-models)
set(CPACK_DEBIAN_MODELS_PACKAGE_ARCHITECTURE all)
set(CPACK_DEBIAN_MODELS_PACKAGE_SHLIBDEPS OFF)
set(CPACK_COMPONENT_MODELS_DESCRIPTION "${_summary} - trained models\n${_about}\n\nThis package holds the trained NH-Net models every front end shares.")

set(CPACK_DEBIAN_CLI_PACKAGE_NAME nhnet-cli)
set(CPACK_COMPONENT_CLI_DEPENDS models)
set(CPACK_COMPONENT_CLI_DESCRIPTION "${_summary} - command-line tool\n${_about}\n\nThis package holds nhnet-cli (estimate, denoise, eval).")

set(CPACK_DEBIAN_PYTHON_PACKAGE_NAME python3-nhnet)
set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
set(CPACK_COMPONENT_PYTHON_DEPENDS models)
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS "python3 (>= 3.11), python3 (<< 3.12), python3-numpy")
set(CPACK_DEBIAN_PYTHON_PACKAGE_RECOMMENDS "python3-distributed, libblis4-openmp")
# py3compile / py3clean (python3-minimal), as dh_python3 would add: __pycache__ goes with a purge.
set(CPACK_DEBIAN_PYTHON_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/cmake/debian/python3-nhnet/postinst
    ${PROJECT_SOURCE_DIR}/cmake/debian/python3-nhnet/prerm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_COMPONENT_PYTHON_DESCRIPTION "${_summary} - Python 3 module\n${_about}\n\nThis package holds the Python 3 module nhnet and its Dask front end\nnhnet.distributed.")

set(CPACK_DEBIAN_DEV_PACKAGE_NAME libnhnet-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_COMPONENT_DEV_DEPENDS models)
# What find_package(nhnet) and the static library's links need (cmake/nhnetConfig.cmake.in).
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
    "libeigen3-dev, libcgal-dev, libnanoflann-dev, libtorch-dev, libpcl-dev, libgomp1, cmake")
set(CPACK_COMPONENT_DEV_DESCRIPTION "${_summary} - development files\n${_about}\n\nThis package holds the C++ headers, the static library, the CMake package\n(find_package(nhnet): nhnet::core, nhnet::pcl) and the PCL-style class.")

nhnet_deb_installed_version(meshlab _meshlab_version)
set(CPACK_DEBIAN_MESHLAB_PLUGIN_PACKAGE_NAME meshlab-plugin-nhnet)
set(CPACK_DEBIAN_MESHLAB_PLUGIN_PACKAGE_SECTION graphics)
set(CPACK_COMPONENT_MESHLAB_PLUGIN_DEPENDS models)
set(CPACK_DEBIAN_MESHLAB_PLUGIN_PACKAGE_DEPENDS "meshlab (= ${_meshlab_version})")
set(CPACK_COMPONENT_MESHLAB_PLUGIN_DESCRIPTION "${_summary} - MeshLab filter\n${_about}\n\nThis package adds Filters > Point Set > Estimate normals (NH-Net) and\nNormal-guided denoise to MeshLab ${_meshlab_version}.")

nhnet_deb_installed_version(cloudcompare _cc_version)
set(CPACK_DEBIAN_CLOUDCOMPARE_PLUGIN_PACKAGE_NAME cloudcompare-plugin-nhnet)
set(CPACK_DEBIAN_CLOUDCOMPARE_PLUGIN_PACKAGE_SECTION graphics)
set(CPACK_COMPONENT_CLOUDCOMPARE_PLUGIN_DEPENDS models)
set(CPACK_DEBIAN_CLOUDCOMPARE_PLUGIN_PACKAGE_DEPENDS "cloudcompare (= ${_cc_version})")
set(CPACK_COMPONENT_CLOUDCOMPARE_PLUGIN_DESCRIPTION "${_summary} - CloudCompare plugin\n${_about}\n\nThis package adds Plugins > NH-Net normals and the -NHNET_NORMALS and\n-NHNET_DENOISE commands to CloudCompare ${_cc_version}.")

# nhnet-cli's manual page, from its --help (help2man), as Debian asks of a program in /usr/bin.
find_program(NHNET_HELP2MAN help2man)
if(NHNET_HELP2MAN AND TARGET nhnet-cli)
  set(_man ${PROJECT_BINARY_DIR}/debian-doc/nhnet-cli.1)
  add_custom_command(OUTPUT ${_man}.gz
    COMMAND ${NHNET_HELP2MAN} --no-info --name "normal estimation for unstructured point clouds"
            --include ${PROJECT_SOURCE_DIR}/cmake/debian/nhnet-cli.h2m --output ${_man}
            $<TARGET_FILE:nhnet-cli>
    COMMAND gzip -9nf ${_man}
    DEPENDS nhnet-cli ${PROJECT_SOURCE_DIR}/cmake/debian/nhnet-cli.h2m VERBATIM)
  add_custom_target(nhnet_cli_manpage ALL DEPENDS ${_man}.gz)
  install(FILES ${_man}.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT cli)
else()
  message(WARNING "nhnet: no help2man (scripts/install-deps.sh installs it): nhnet-cli's "
                  "package goes without its manual page")
endif()

set(CPACK_COMPONENTS_ALL models cli python dev)
if(NHNET_MESHLAB_PLUGIN_BUILT)
  list(APPEND CPACK_COMPONENTS_ALL meshlab_plugin)
endif()
if(TARGET nhnet_cloudcompare)
  list(APPEND CPACK_COMPONENTS_ALL cloudcompare_plugin)
endif()
foreach(_comp IN LISTS CPACK_COMPONENTS_ALL)
  string(TOUPPER ${_comp} _up)
  nhnet_deb_docs(${_comp} ${CPACK_DEBIAN_${_up}_PACKAGE_NAME})
endforeach()
include(CPack)
