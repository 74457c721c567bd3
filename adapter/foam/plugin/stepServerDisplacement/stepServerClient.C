/*---------------------------------------------------------------------------*\
    stepServerClient, the messages: frames and the payloads of
    docs/protocol.md (version 2). The socket stream is in stepServerStream.C,
    the byte encoding in stepServerWire.H.
\*---------------------------------------------------------------------------*/

#include "stepServerClient.H"
#include "stepServerWire.H"

#include <cmath>
#include <cstring>
#include <sstream>

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

stepServerClient::stepServerClient(const Endpoint& ep)
:
    endpoint_(ep)
{}


stepServerClient::~stepServerClient()
{
    close();
}


// * * * * * * * * * * * * * * Private helpers  * * * * * * * * * * * * * * //

void stepServerClient::fail(const std::string& msg)
{
    close();
    throw stepServerError(msg + " (server " + endpoint_.describe() + ")");
}


std::uint32_t stepServerClient::sendFrame
(
    MsgType type,
    const std::vector<unsigned char>& payload
)
{
    if (fd_ < 0)
    {
        throw stepServerError
        (
            std::string("cannot send ") + typeName(type)
          + ": not connected to " + endpoint_.describe()
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
    sendAll(buf);
    return seq;
}


std::vector<unsigned char> stepServerClient::recvReply
(
    std::uint32_t seq,
    MsgType expected,
    const char* what
)
{
    unsigned char h[headerSize];
    recvAll(h, headerSize);

    const std::string ctx = std::string(" in reply to ") + what;
    if (std::memcmp(h, magic, 4) != 0)
    {
        fail("malformed reply" + ctx + ": bad magic");
    }
    const std::uint16_t ver = getU16(h + versionAt);
    const std::uint16_t type = getU16(h + typeAt);
    const std::uint32_t len = getU32(h + lengthAt);
    const std::uint32_t rseq = getU32(h + seqAt);

    if (len > maxPayload)
    {
        fail("malformed reply" + ctx + ": payload length " + std::to_string(len)
           + " over the 64 MiB limit");
    }
    std::vector<unsigned char> payload(len);
    if (len) recvAll(payload.data(), len);

    if (type == ERROR)
    {
        std::uint32_t code = len >= 4 ? getU32(payload.data()) : 0;
        std::string msg
        (
            len > 4 ? reinterpret_cast<const char*>(payload.data()) + 4 : "",
            len > 4 ? len - 4 : 0
        );
        fail("server ERROR " + std::to_string(code) + ctx + ": " + msg);
    }
    if (ver != version)
    {
        fail("protocol version mismatch" + ctx + ": server speaks "
           + std::to_string(ver) + ", client " + std::to_string(version));
    }
    if (type != expected)
    {
        fail(std::string("unexpected ") + typeName(type) + " (type "
           + std::to_string(type) + ")" + ctx + ", expected "
           + typeName(expected));
    }
    if (rseq != seq)
    {
        fail("reply" + ctx + " carries sequence number "
           + std::to_string(rseq) + ", expected " + std::to_string(seq));
    }
    return payload;
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Welcome stepServerClient::hello
(
    std::uint32_t nRanks,
    const std::string& token,
    const std::vector<double>& points
)
{
    if (points.size() % 3)
    {
        throw stepServerError("HELLO: point array size not a multiple of 3");
    }
    nPoints_ = points.size()/3;

    std::vector<unsigned char> p;
    p.reserve(12 + token.size() + 8*points.size());
    putU32(p, nRanks);
    putU32(p, std::uint32_t(nPoints_));
    putU32(p, std::uint32_t(token.size()));
    p.insert(p.end(), token.begin(), token.end());
    for (double x : points) putF64(p, x);

    const std::uint32_t seq = sendFrame(HELLO, p);
    const auto r = recvReply(seq, WELCOME, "HELLO");
    if (r.size() != 20)
    {
        fail("malformed WELCOME: payload of " + std::to_string(r.size())
           + " bytes, expected 20");
    }
    Welcome w;
    w.nPoints = getU32(r.data());
    w.maxMappingDistance = getF64(r.data() + 4);
    w.internalStep = getF64(r.data() + 12);
    if (w.nPoints != nPoints_)
    {
        fail("WELCOME accepted " + std::to_string(w.nPoints)
           + " points, but HELLO sent " + std::to_string(nPoints_));
    }
    return w;
}


std::vector<double> stepServerClient::request
(
    double t,
    const std::array<double, 3>& pressureForce,
    const std::array<double, 3>& viscousForce
)
{
    std::vector<unsigned char> p;
    p.reserve(56);
    putF64(p, t);
    for (double f : pressureForce) putF64(p, f);
    for (double f : viscousForce) putF64(p, f);

    const std::uint32_t seq = sendFrame(REQUEST, p);
    const auto r = recvReply(seq, DISPLACEMENT, "REQUEST");

    const std::size_t expected = 12 + 24*nPoints_;
    if (r.size() < 12 || r.size() != expected)
    {
        fail("malformed DISPLACEMENT: payload of " + std::to_string(r.size())
           + " bytes, expected " + std::to_string(expected)
           + " for " + std::to_string(nPoints_) + " points");
    }
    const double rt = getF64(r.data());
    const std::uint32_t n = getU32(r.data() + 8);
    if (n != nPoints_)
    {
        fail("DISPLACEMENT for " + std::to_string(n) + " points, expected "
           + std::to_string(nPoints_));
    }
    if (rt != t)
    {
        std::ostringstream os;
        os.precision(17);
        os << "DISPLACEMENT for time " << rt << ", requested " << t;
        fail(os.str());
    }
    std::vector<double> d(3*nPoints_);
    for (std::size_t i = 0; i < d.size(); ++i)
    {
        d[i] = getF64(r.data() + 12 + 8*i);
        if (!std::isfinite(d[i]))
        {
            fail("DISPLACEMENT contains a non-finite value at point "
               + std::to_string(i/3));
        }
    }
    return d;
}


void stepServerClient::write(double t)
{
    std::vector<unsigned char> p;
    putF64(p, t);
    const std::uint32_t seq = sendFrame(WRITE, p);
    const auto r = recvReply(seq, ACK, "WRITE");
    if (!r.empty())
    {
        fail("malformed ACK: payload of " + std::to_string(r.size())
           + " bytes, expected 0");
    }
}


void stepServerClient::bye() noexcept
{
    if (fd_ < 0) return;
    try
    {
        sendFrame(BYE, {});
    }
    catch (...)
    {}
    close();
}


} // End namespace stepServer
