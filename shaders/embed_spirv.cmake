# cmake -DSPV=in.spv -DOUT=out.cpp -DNAME=name -P embed_spirv.cmake
# Writes the SPIR-V words of in.spv as `mchex::spirv::NAME` (host/backends/vk_spirv.h declares them).
# SPIR-V is a stream of 32-bit words in the producer's byte order (little-endian from glslang);
# the words are read back in the same order, so the array holds the module as the driver wants it.
file(READ ${SPV} hex HEX)
string(LENGTH "${hex}" n)
math(EXPR rem "${n} % 8")
if(NOT rem EQUAL 0 OR n EQUAL 0)
  message(FATAL_ERROR "${SPV}: not a whole number of 32-bit words")
endif()
string(REGEX MATCHALL "([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])" bytes "${hex}")
set(words "")
set(count 0)
foreach(w ${bytes})
  string(SUBSTRING "${w}" 0 2 b0)
  string(SUBSTRING "${w}" 2 2 b1)
  string(SUBSTRING "${w}" 4 2 b2)
  string(SUBSTRING "${w}" 6 2 b3)
  string(APPEND words "0x${b3}${b2}${b1}${b0}u,")
  math(EXPR count "${count} + 1")
  math(EXPR col "${count} % 8")
  if(col EQUAL 0)
    string(APPEND words "\n")
  endif()
endforeach()
file(WRITE ${OUT} "// Generated from ${NAME}.comp by shaders/embed_spirv.cmake; do not edit.\n"
  "#include \"host/backends/vk_spirv.h\"\n\nnamespace mchex::spirv {\n"
  "static const std::uint32_t words_${NAME}[] = {\n${words}};\n"
  "const std::span<const std::uint32_t> ${NAME}(words_${NAME});\n}  // namespace mchex::spirv\n")
