# Where everything goes on install, in one place (the Debian package, scripts/build-deb.sh,
# is `cmake --install` into a staging folder). Targets by name, wherever their sources live.
#   /usr/bin/{vgrd,vgr,vgr-sim-camera,vgr-sim-plc,vgr-sim-robot}
#   /usr/lib/systemd/system/vgrd.service, /usr/lib/sysusers.d/vgr.conf, /usr/lib/tmpfiles.d/vgr.conf
#   /etc/vgr/cell.yaml (+ sim-calib/*.yaml)  the example sim cell, journal in /var/lib/vgr
#   /usr/share/vgr/robot/                    robot-side programs (examples/robot/)
#   /usr/share/vgr/models/grasp/ggcnn.onnx   the grasp network (models/grasp/, docs/grasp.md)
#   /usr/share/doc/vgr/                      README.md, docs/*.md
# With the prefix /usr the configuration goes to /etc (not /usr/etc), decided at install
# time, so `cmake --install build --prefix /usr` of a tree configured with the default
# prefix still puts it right.
include(GNUInstallDirs)

install(TARGETS vgrd vgr vgr-sim-camera vgr-sim-plc vgr-sim-robot RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

install(FILES ${PROJECT_SOURCE_DIR}/systemd/vgrd.service DESTINATION lib/systemd/system)
install(FILES ${PROJECT_SOURCE_DIR}/systemd/vgr.sysusers DESTINATION lib/sysusers.d RENAME vgr.conf)
install(FILES ${PROJECT_SOURCE_DIR}/systemd/vgr.tmpfiles DESTINATION lib/tmpfiles.d RENAME vgr.conf)

file(GLOB VGR_ROBOT_PROGRAMS ${PROJECT_SOURCE_DIR}/examples/robot/*)
install(FILES ${VGR_ROBOT_PROGRAMS} DESTINATION ${CMAKE_INSTALL_DATADIR}/vgr/robot)
install(FILES ${PROJECT_SOURCE_DIR}/models/grasp/ggcnn.onnx DESTINATION ${CMAKE_INSTALL_DATADIR}/vgr/models/grasp)
file(GLOB VGR_DOCS ${PROJECT_SOURCE_DIR}/docs/*.md)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${VGR_DOCS} DESTINATION ${CMAKE_INSTALL_DOCDIR})

# The packaged /etc/vgr/cell.yaml: the sim cell example with its journal in the state
# directory (the only writable place under the unit's ProtectSystem=strict).
file(READ ${PROJECT_SOURCE_DIR}/config/examples/sim-cell.yaml VGR_CELL_YAML)
string(REGEX REPLACE "journal: [^ \n]+" "journal: /var/lib/vgr/journal.jsonl" VGR_CELL_YAML "${VGR_CELL_YAML}")
file(WRITE ${CMAKE_BINARY_DIR}/generated/cell.yaml
     "# vgrd's cell config (docs in /usr/share/doc/vgr). This is the simulated example cell\n"
     "# (camera emulator vgr-sim-camera on 127.0.0.1): edit it for your cell, check it with\n"
     "# `vgrd --check --config /etc/vgr/cell.yaml`, then `systemctl enable --now vgrd`.\n"
     "${VGR_CELL_YAML}")
set(VGR_ETC_FILES ${CMAKE_BINARY_DIR}/generated/cell.yaml)
install(CODE "
  if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
    set(vgr_etc /etc/vgr)
  else()
    set(vgr_etc \"\${CMAKE_INSTALL_PREFIX}/etc/vgr\")
  endif()
  file(INSTALL DESTINATION \"\${vgr_etc}\" TYPE FILE FILES \"${CMAKE_BINARY_DIR}/generated/cell.yaml\")
  file(INSTALL DESTINATION \"\${vgr_etc}/sim-calib\" TYPE FILE FILES
       \"${PROJECT_SOURCE_DIR}/config/examples/sim-calib/intrinsics.yaml\"
       \"${PROJECT_SOURCE_DIR}/config/examples/sim-calib/handeye.yaml\"
       \"${PROJECT_SOURCE_DIR}/config/examples/sim-calib/plane.yaml\")
")
