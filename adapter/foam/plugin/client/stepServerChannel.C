/*---------------------------------------------------------------------------*\
    stepServerChannel, the frames of docs/protocol.md (version 3) on the
    socket stream (stepServerStream.C); the byte encoding is in
    stepServerWire.H.
\*---------------------------------------------------------------------------*/

#include "stepServerChannel.H"

#include <cstring>
#include <string>

namespace stepServer
{

using namespace wire;

const char* wire::typeName(std::uint16_t t)
{
    switch (t)
    {
        case HELLO: return "HELLO";
        case WELCOME: return "WELCOME";
        case REQUEST: return "REQUEST";
        case DISPLACEMENT: return "DISPLACEMENT";
        case WRITE: return "WRITE";
        case ACK: return "ACK";
        case BYE: return "BYE";
        case ERROR: return "ERROR";
        default: return "unknown";
    }
}


// * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * * //

stepServerChannel::stepServerChannel(const Endpoint& ep) :
    stream_(ep)
{}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void stepServerChannel::connect()
{
    if (stream_.connected()) return;

    stream_.connect();
    seq_ = 0;
}


std::uint32_t stepServerChannel::sendFrame(
    MsgType type,
    const std::vector<unsigned char>& payload
)
{
    if (!stream_.connected())
    {
        throw stepServerError(
            std::string("cannot send ") + typeName(type) + ": not connected to "
            + stream_.endpoint().describe()
        );
    }
    std::vector<unsigned char> buf;
    buf.reserve(headerSize + payload.size());
    for (std::size_t i = 0; i < 4; ++i)
    {
        buf.push_back(magic[i]);
    }
    putU16(buf, version);
    putU16(buf, type);
    putU32(buf, std::uint32_t(payload.size()));
    const std::uint32_t seq = ++seq_;
    putU32(buf, seq);
    buf.insert(buf.end(), payload.begin(), payload.end());
    stream_.sendAll(buf);
    return seq;
}


std::vector<unsigned char> stepServerChannel::recvReply(
    std::uint32_t seq,
    MsgType expected,
    const char* what
)
{
    unsigned char h[headerSize];
    stream_.recvAll(h, headerSize);

    const std::string ctx = std::string(" in reply to ") + what;
    if (std::memcmp(h, magic, 4) != 0)
    {
        stream_.fail("malformed reply" + ctx + ": bad magic");
    }
    const std::uint16_t ver = getU16(h + versionAt);
    const std::uint16_t type = getU16(h + typeAt);
    const std::uint32_t len = getU32(h + lengthAt);
    const std::uint32_t rseq = getU32(h + seqAt);

    if (len > maxPayload)
    {
        stream_.fail(
            "malformed reply" + ctx + ": payload length " + std::to_string(len)
            + " over the 64 MiB limit"
        );
    }
    std::vector<unsigned char> payload(len);
    if (len) stream_.recvAll(payload.data(), len);

    if (type == ERROR)
    {
        std::uint32_t code = len >= 4 ? getU32(payload.data()) : 0;
        std::string msg(
            len > 4 ? reinterpret_cast<const char*>(payload.data()) + 4 : "",
            len > 4 ? len - 4 : 0
        );
        stream_.fail("server ERROR " + std::to_string(code) + ctx + ": " + msg);
    }
    if (ver != version)
    {
        stream_.fail(
            "protocol version mismatch" + ctx + ": server speaks "
            + std::to_string(ver) + ", client " + std::to_string(version)
        );
    }
    if (type != expected)
    {
        stream_.fail(
            std::string("unexpected ") + typeName(type) + " (type "
            + std::to_string(type) + ")" + ctx + ", expected "
            + typeName(expected)
        );
    }
    if (rseq != seq)
    {
        stream_.fail(
            "reply" + ctx + " carries sequence number " + std::to_string(rseq)
            + ", expected " + std::to_string(seq)
        );
    }
    return payload;
}

} // End namespace stepServer
