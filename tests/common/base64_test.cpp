// Base64 against the RFC 4648 test vectors (section 10), and bytes that are not text.
#include <gtest/gtest.h>

#include <string>

#include "runout/common/base64.hpp"

using runout::base64_encode;

TEST(common_base64, Rfc4648Vectors) {
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foob"), "Zm9vYg==");
  EXPECT_EQ(base64_encode("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
}

TEST(common_base64, BinaryBytesAndLongInputHaveNoLineBreaks) {
  // A PNG signature (high bytes and a NUL) and 3 000 bytes: one line, as a data: URI needs.
  EXPECT_EQ(base64_encode(std::string("\x89PNG\r\n\x1a\n\0", 9)), "iVBORw0KGgoA");
  const std::string long_text = base64_encode(std::string(3000, '\xff'));
  EXPECT_EQ(long_text.size(), 4000u);
  EXPECT_EQ(long_text.find('\n'), std::string::npos);
  EXPECT_EQ(long_text.substr(0, 8), "////////");
}
