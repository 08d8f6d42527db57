# ej_add_plugin(NAME SOURCES...): one plugin folder = one shared object ej_<NAME>.so,
# exporting only ej_plugin_info_v1, plus an object library ej_<NAME>_obj that tests link
# statically through ej_plugin_<NAME>_info().
function(ej_add_plugin name)
  add_library(ej_${name} MODULE ${ARGN})
  target_link_libraries(ej_${name} PRIVATE ejecta OpenMP::OpenMP_C m)
  target_compile_definitions(ej_${name} PRIVATE EJ_PLUGIN_SHARED)
  set_target_properties(ej_${name} PROPERTIES PREFIX "" C_VISIBILITY_PRESET hidden
    LIBRARY_OUTPUT_DIRECTORY ${EJ_PLUGIN_BUILD_DIR})
  install(TARGETS ej_${name} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/ejecta/plugins)
  add_library(ej_${name}_obj OBJECT ${ARGN})
  target_link_libraries(ej_${name}_obj PRIVATE ejecta OpenMP::OpenMP_C)
  set_property(GLOBAL APPEND PROPERTY EJ_PLUGINS ${name})
endfunction()
