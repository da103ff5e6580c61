// SPDX-License-Identifier: BSD-3-Clause
// checkOnnxModel: the protobuf wire format of onnx.proto (ModelProto → GraphProto →
// NodeProto/AttributeProto → TensorProto), walked with the few field numbers below; no
// protobuf library is needed for it, and none could be trusted more with a hostile file
// than these bounds-checked reads.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/recognition/onnx_model_check.h>

#include <cstring>
#include <set>
#include <string>
#include <vector>

namespace cuefusion
{
namespace recognition
{
namespace
{
// Field numbers of onnx.proto (ONNX IR version 9).
constexpr std::uint32_t kModelGraph = 7;
constexpr std::uint32_t kGraphNode = 1, kGraphInitializer = 5, kGraphInput = 11, kGraphOutput = 12,
                        kGraphSparseInitializer = 15;
constexpr std::uint32_t kNodeInput = 1, kNodeOutput = 2, kNodeAttribute = 5;
constexpr std::uint32_t kValueInfoName = 1, kTensorName = 8;
constexpr std::uint32_t kAttributeTensor = 5, kAttributeGraph = 6, kAttributeTensors = 10, kAttributeGraphs = 11,
                        kAttributeSparseTensor = 22, kAttributeSparseTensors = 23;
constexpr std::uint32_t kSparseValues = 1, kSparseIndices = 2;
constexpr std::uint32_t kTensorDims = 1, kTensorDataType = 2, kTensorFloatData = 4, kTensorInt32Data = 5,
                        kTensorStringData = 6, kTensorInt64Data = 7, kTensorRawData = 9, kTensorDoubleData = 10,
                        kTensorExternalData = 13, kTensorDataLocation = 14, kTensorUint64Data = 11;
constexpr std::uint64_t kMaxValues = std::uint64_t{1} << 31;
constexpr int kMaxGraphDepth = 16;

enum WireType : std::uint32_t
{
  kVarint = 0,
  kFixed64 = 1,
  kLengthDelimited = 2,
  kFixed32 = 5
};

/** One protobuf message's bytes, read field by field; every read checked against its end. */
class Message
{
public:
  Message (const char* begin, const char* end, const std::string& source) : at_ (begin), end_ (end), source_ (source) {}

  struct Field
  {
    std::uint32_t number = 0;
    std::uint32_t wire = 0;
    std::uint64_t value = 0;            ///< varint and fixed values
    const char* bytes = nullptr;        ///< length-delimited contents
    std::uint64_t size = 0;
  };

  bool
  next (Field& f)
  {
    if (at_ == end_)
      return false;
    const std::uint64_t key = varint ();
    f.number = static_cast<std::uint32_t> (key >> 3);
    f.wire = static_cast<std::uint32_t> (key & 7u);
    if (f.number == 0 || key >> 32)
      fail ("a field number out of range");
    switch (f.wire)
    {
      case kVarint:
        f.value = varint ();
        break;
      case kFixed64:
        f.value = fixed (8);
        break;
      case kFixed32:
        f.value = fixed (4);
        break;
      case kLengthDelimited:
        f.size = varint ();
        if (f.size > static_cast<std::uint64_t> (end_ - at_))
          fail ("a field longer than the file");
        f.bytes = at_;
        at_ += f.size;
        break;
      default:
        fail ("an unknown protobuf wire type " + std::to_string (f.wire));
    }
    return true;
  }

  Message
  sub (const Field& f) const
  {
    if (f.wire != kLengthDelimited)
      fail ("field " + std::to_string (f.number) + " is not a message");
    return Message (f.bytes, f.bytes + f.size, source_);
  }

  /** Calls \a take with each varint of a packed repeated field. */
  template <typename F>
  void
  forEachPacked (const Field& f, F&& take) const
  {
    Message packed (f.bytes, f.bytes + f.size, source_);
    while (packed.at_ != packed.end_)
      take (packed.varint ());
  }

  /** Number of values in a repeated varint field: one when unpacked, else those packed. */
  std::uint64_t
  countVarints (const Field& f) const
  {
    std::uint64_t n = 0;
    if (f.wire == kLengthDelimited)
      forEachPacked (f, [&n] (std::uint64_t) { ++n; });
    else
      n = 1;
    return n;
  }

  [[noreturn]] void
  fail (const std::string& what) const
  {
    throw Error (source_, "not a sound ONNX model: " + what);
  }

private:
  std::uint64_t
  varint ()
  {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7)
    {
      if (at_ == end_)
        fail ("the file ends inside a number");
      const auto byte = static_cast<unsigned char> (*at_++);
      v |= static_cast<std::uint64_t> (byte & 0x7fu) << shift;
      if (!(byte & 0x80u))
        return v;
    }
    fail ("a number longer than ten bytes");
  }

  std::uint64_t
  fixed (int bytes)
  {
    if (end_ - at_ < bytes)
      fail ("the file ends inside a number");
    std::uint64_t v = 0;
    std::memcpy (&v, at_, static_cast<std::size_t> (bytes));  // little-endian hosts only (x86, ARM)
    at_ += bytes;
    return v;
  }

  const char* at_;
  const char* end_;
  const std::string& source_;
};

/** Bytes of one value of an ONNX TensorProto.DataType (0 = string or unknown). */
std::uint64_t
elementBytes (std::uint64_t data_type)
{
  switch (data_type)
  {
    case 2: case 3: case 9: return 1;                // uint8, int8, bool
    case 4: case 5: case 10: case 16: return 2;      // uint16, int16, float16, bfloat16
    case 1: case 6: case 12: return 4;               // float, int32, uint32
    case 7: case 11: case 13: case 14: return 8;     // int64, double, uint64, complex64
    case 15: return 16;                              // complex128
    default: return 0;
  }
}

void
checkTensor (Message m)
{
  std::uint64_t values = 1, data_type = 0, raw_bytes = 0, typed = 0, strings = 0;
  bool has_raw = false;
  Message::Field f;
  while (m.next (f))
  {
    if (f.number == kTensorDims)
    {
      const auto multiply = [&] (std::uint64_t d) {
        if (d >> 63)
          m.fail ("a tensor with a negative dimension");
        if (d != 0 && values > kMaxValues / d)
          m.fail ("a tensor of more than 2^31 values");
        values *= d;
      };
      if (f.wire == kLengthDelimited)
        m.forEachPacked (f, multiply);
      else
        multiply (f.value);
    }
    else if (f.number == kTensorDataType)
      data_type = f.value;
    else if (f.number == kTensorRawData)
    {
      has_raw = true;
      raw_bytes = f.size;
    }
    else if (f.number == kTensorFloatData)
      typed += f.wire == kLengthDelimited ? f.size / 4 : 1;
    else if (f.number == kTensorDoubleData)
      typed += f.wire == kLengthDelimited ? f.size / 8 : 1;
    else if (f.number == kTensorInt32Data || f.number == kTensorInt64Data || f.number == kTensorUint64Data)
      typed += m.countVarints (f);
    else if (f.number == kTensorStringData)
      ++strings;
    else if (f.number == kTensorExternalData)
      m.fail ("a tensor with external data (only self-contained models are loaded)");
    else if (f.number == kTensorDataLocation && f.value != 0)
      m.fail ("a tensor with external data (only self-contained models are loaded)");
  }
  if (data_type == 8)  // strings: one entry per value
  {
    if (strings != values)
      m.fail ("a string tensor whose dims promise " + std::to_string (values) + " values and which holds " + std::to_string (strings));
    return;
  }
  const std::uint64_t size = elementBytes (data_type);
  if (size == 0)
    m.fail ("a tensor of unknown data type " + std::to_string (data_type));
  // complex values are two numbers in the typed fields
  const std::uint64_t per_value = data_type == 14 || data_type == 15 ? 2 : 1;
  const std::uint64_t held = has_raw ? (raw_bytes % size == 0 ? raw_bytes / size : ~std::uint64_t{0}) : typed / per_value;
  if (held != values)
    m.fail ("a tensor whose dims promise " + std::to_string (values) + " values and which holds " +
            (held == ~std::uint64_t{0} ? std::string ("a partial value") : std::to_string (held)));
}

using Names = std::set<std::string>;

void checkGraph (Message m, int depth, const Names& outer);

/** The string field \a number of a message (its last occurrence), or "". */
std::string
stringField (Message m, std::uint32_t number)
{
  std::string value;
  Message::Field f;
  while (m.next (f))
    if (f.number == number && f.wire == kLengthDelimited)
      value.assign (f.bytes, f.size);
  return value;
}

void
checkSparseTensor (Message m, Names* defined)
{
  Message::Field f;
  while (m.next (f))
    if (f.number == kSparseValues || f.number == kSparseIndices)
    {
      checkTensor (m.sub (f));
      if (defined && f.number == kSparseValues)
        defined->insert (stringField (m.sub (f), kTensorName));
    }
}

void
checkAttribute (Message m, int depth, const Names& visible)
{
  Message::Field f;
  while (m.next (f))
  {
    if (f.number == kAttributeTensor || f.number == kAttributeTensors)
      checkTensor (m.sub (f));
    else if (f.number == kAttributeSparseTensor || f.number == kAttributeSparseTensors)
      checkSparseTensor (m.sub (f), nullptr);
    else if (f.number == kAttributeGraph || f.number == kAttributeGraphs)
      checkGraph (m.sub (f), depth + 1, visible);
  }
}

/** Every tensor checked, and every name a node or the graph's outputs use defined before
  * it (a graph input, an initializer, an earlier node's output, or a name of the graphs
  * around it): OpenCV's importer dereferences what it looks up by name. */
void
checkGraph (Message m, int depth, const Names& outer)
{
  if (depth > kMaxGraphDepth)
    m.fail ("graphs nested more than " + std::to_string (kMaxGraphDepth) + " deep");
  Names defined = outer;
  Message::Field f;
  for (Message pass = m; pass.next (f);)
  {
    if (f.number == kGraphInitializer)
    {
      checkTensor (pass.sub (f));
      defined.insert (stringField (pass.sub (f), kTensorName));
    }
    else if (f.number == kGraphSparseInitializer)
      checkSparseTensor (pass.sub (f), &defined);
    else if (f.number == kGraphInput)
      defined.insert (stringField (pass.sub (f), kValueInfoName));
  }
  for (Message pass = m; pass.next (f);)
  {
    if (f.number == kGraphNode)
    {
      Message node = pass.sub (f);
      Message::Field a;
      std::vector<std::string> outputs;
      for (Message fields = node; fields.next (a);)
      {
        if (a.number == kNodeInput)
        {
          const std::string name = a.wire == kLengthDelimited ? std::string (a.bytes, a.size) : std::string ("?");
          if (!name.empty () && !defined.count (name))
            m.fail ("a node reads '" + name.substr (0, 64) + "', which nothing before it defines");
        }
        else if (a.number == kNodeOutput && a.wire == kLengthDelimited)
          outputs.emplace_back (a.bytes, a.size);
        else if (a.number == kNodeAttribute)
          checkAttribute (node.sub (a), depth, defined);
      }
      defined.insert (outputs.begin (), outputs.end ());
    }
    else if (f.number == kGraphOutput)
    {
      const std::string name = stringField (pass.sub (f), kValueInfoName);
      if (!defined.count (name))
        m.fail ("the graph's output '" + name.substr (0, 64) + "' is defined nowhere");
    }
  }
}
}  // namespace

void
checkOnnxModelBytes (const std::string& bytes, const std::string& source)
{
  Message model (bytes.data (), bytes.data () + bytes.size (), source);
  Message::Field f;
  bool graph = false;
  while (model.next (f))
    if (f.number == kModelGraph)
    {
      checkGraph (model.sub (f), 0, Names ());
      graph = true;
    }
  if (!graph)
    model.fail ("no graph");
}

void
checkOnnxModel (const std::string& path)
{
  const FileContext context (path);
  if (io::requireRegularFile (path) > kMaxOnnxFileBytes)
    throw Error (path, "larger than 1 GiB, the most cuefusion loads as an ONNX model");
  checkOnnxModelBytes (io::readTextFile (path), path);
}
}  // namespace recognition
}  // namespace cuefusion
