# The API reference (docs/Doxyfile.in): the four layers' public headers through doxygen (Debian
# package doxygen, in scripts/packages-test.txt), HTML into build/<preset>/docs/api/html. The
# Doxyfile is configured whether or not doxygen is installed, so that the api_reference test
# (tests/tools/CMakeLists.txt) can name the missing package; the api_docs target exists only
# when doxygen is found.
find_package(Doxygen)
set(PBDAM_API_DOCS_DIR ${PROJECT_BINARY_DIR}/docs/api)
set(PBDAM_DOXYFILE ${PROJECT_BINARY_DIR}/docs/Doxyfile)
configure_file(${PROJECT_SOURCE_DIR}/docs/Doxyfile.in ${PBDAM_DOXYFILE} @ONLY)
if(DOXYGEN_FOUND)
  file(GLOB PBDAM_PUBLIC_HEADERS CONFIGURE_DEPENDS
       ${PROJECT_SOURCE_DIR}/formats/include/pbdam/formats/*.h
       ${PROJECT_SOURCE_DIR}/runtime/include/pbdam/runtime/*.h
       ${PROJECT_SOURCE_DIR}/streaming/include/pbdam/streaming/*.h
       ${PROJECT_SOURCE_DIR}/gpu/include/pbdam/gpu/*.h)
  add_custom_command(OUTPUT ${PBDAM_API_DOCS_DIR}/html/index.html
                     COMMAND Doxygen::doxygen ${PBDAM_DOXYFILE}
                     DEPENDS ${PBDAM_DOXYFILE} ${PBDAM_PUBLIC_HEADERS}
                             ${PROJECT_SOURCE_DIR}/docs/embedding.md
                     COMMENT "API reference: ${PBDAM_API_DOCS_DIR}/html/index.html"
                     VERBATIM)
  add_custom_target(api_docs DEPENDS ${PBDAM_API_DOCS_DIR}/html/index.html)
endif()
