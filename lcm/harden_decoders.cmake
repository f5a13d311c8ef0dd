# Post-processes a header written by lcm-gen (run by lcm/CMakeLists.txt after every
# generation): its string decoder checks a length only against the bytes left,
#   if(__x_len__ > maxlen - pos) return -1;  x.assign(buf + pos, __x_len__ - 1);
# so a length of INT32_MIN from the network makes `__x_len__ - 1` overflow (undefined
# behaviour) and any length <= 0 reaches std::string::assign with a huge size (issue 14).
# Every such check is rewritten to refuse a length <= 0 (an LCM string's length counts its
# NUL terminator, so a valid one is >= 1); the build fails if lcm-gen's output changes so
# that a string decode would be left unguarded.
# Usage: cmake -DHEADER=<file> -P harden_decoders.cmake
cmake_minimum_required(VERSION 3.16)
file(READ "${HEADER}" text)
if(text MATCHES "hardened: issue 14")
  return()  # already post-processed
endif()
string(REGEX MATCHALL "_len__ - 1\\)" assigns "${text}")
string(REGEX MATCHALL "if\\(__[A-Za-z0-9_]+_len__ > maxlen - pos\\)" guards "${text}")
list(LENGTH assigns n_assigns)
list(LENGTH guards n_guards)
if(NOT n_assigns EQUAL n_guards)
  message(FATAL_ERROR "${HEADER}: ${n_assigns} string decodes but ${n_guards} length checks: "
                      "lcm-gen's output changed, update lcm/harden_decoders.cmake")
endif()
string(REGEX REPLACE "if\\(__([A-Za-z0-9_]+)_len__ > maxlen - pos\\) return -1;"
       "if(__\\1_len__ <= 0 || __\\1_len__ > maxlen - pos) return -1; /* hardened: issue 14 */"
       text "${text}")
file(WRITE "${HEADER}" "${text}")
