/*---------------------------------------------------------------------------*\
    stepServerClient, the messages: the payloads of docs/protocol.md
    (version 3). The frames are in stepServerChannel.C, the socket stream in
    stepServerStream.C, the byte encoding in stepServerWire.H.
\*---------------------------------------------------------------------------*/

#include "stepServerClient.H"
#include "stepServerWire.H"

#include <cmath>
#include <sstream>

namespace stepServer
{

using namespace wire;

// * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * * //

stepServerClient::stepServerClient(const Endpoint& ep) :
    channel_(ep)
{}


stepServerClient::~stepServerClient()
{
    close();
}


// * * * * * * * * * * * * * * Private helpers  * * * * * * * * * * * * * * //

void stepServerClient::fail(const std::string& msg)
{
    channel_.stream().fail(msg);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void stepServerClient::connect()
{
    channel_.connect();
}


Welcome stepServerClient::hello(
    std::uint32_t nRanks,
    const std::string& token,
    const std::vector<double>& points
)
{
    if (points.size() % 3)
    {
        throw stepServerError("HELLO: point array size not a multiple of 3");
    }
    nPoints_ = points.size() / 3;

    std::vector<unsigned char> p;
    p.reserve(12 + token.size() + 8 * points.size());
    putU32(p, nRanks);
    putU32(p, std::uint32_t(nPoints_));
    putU32(p, std::uint32_t(token.size()));
    p.insert(p.end(), token.begin(), token.end());
    for (double x : points) putF64(p, x);

    const std::uint32_t seq = channel_.sendFrame(HELLO, p);
    const auto r = channel_.recvReply(seq, WELCOME, "HELLO");
    if (r.size() != 20)
    {
        fail(
            "malformed WELCOME: payload of " + std::to_string(r.size())
            + " bytes, expected 20"
        );
    }
    Welcome w;
    w.nPoints = getU32(r.data());
    w.maxMappingDistance = getF64(r.data() + 4);
    w.internalStep = getF64(r.data() + 12);
    if (w.nPoints != nPoints_)
    {
        fail(
            "WELCOME accepted " + std::to_string(w.nPoints)
            + " points, but HELLO sent " + std::to_string(nPoints_)
        );
    }
    return w;
}


Displacement stepServerClient::request(double t, const Loads& loads)
{
    std::vector<unsigned char> p;
    p.reserve(104);
    putF64(p, t);
    for (const auto* v :
         {&loads.pressureForce,
          &loads.viscousForce,
          &loads.pressureMoment,
          &loads.viscousMoment})
    {
        for (double x : *v) putF64(p, x);
    }

    const std::uint32_t seq = channel_.sendFrame(REQUEST, p);
    const auto r = channel_.recvReply(seq, DISPLACEMENT, "REQUEST");

    // f64 time, 3 f64 frame velocity, 3 f64 frame acceleration, u32 nPoints
    constexpr std::size_t head = 7 * 8 + 4;
    const std::size_t expected = head + 24 * nPoints_;
    if (r.size() < head || r.size() != expected)
    {
        fail(
            "malformed DISPLACEMENT: payload of " + std::to_string(r.size())
            + " bytes, expected " + std::to_string(expected) + " for "
            + std::to_string(nPoints_) + " points"
        );
    }
    const double rt = getF64(r.data());
    const std::uint32_t n = getU32(r.data() + 56);
    if (n != nPoints_)
    {
        fail(
            "DISPLACEMENT for " + std::to_string(n) + " points, expected "
            + std::to_string(nPoints_)
        );
    }
    if (rt != t)
    {
        std::ostringstream os;
        os.precision(17);
        os << "DISPLACEMENT for time " << rt << ", requested " << t;
        fail(os.str());
    }
    Displacement reply;
    for (std::size_t k = 0; k < 3; ++k)
    {
        reply.frameVelocity[k] = getF64(r.data() + 8 + 8 * k);
        reply.frameAcceleration[k] = getF64(r.data() + 32 + 8 * k);
        if (!std::isfinite(reply.frameVelocity[k])
            || !std::isfinite(reply.frameAcceleration[k]))
        {
            fail("DISPLACEMENT carries a non-finite frame velocity or "
                 "acceleration");
        }
    }
    std::vector<double>& d = reply.d;
    d.resize(3 * nPoints_);
    for (std::size_t i = 0; i < d.size(); ++i)
    {
        d[i] = getF64(r.data() + head + 8 * i);
        if (!std::isfinite(d[i]))
        {
            fail(
                "DISPLACEMENT contains a non-finite value at point "
                + std::to_string(i / 3)
            );
        }
    }
    return reply;
}


void stepServerClient::write(double t)
{
    std::vector<unsigned char> p;
    putF64(p, t);
    const std::uint32_t seq = channel_.sendFrame(WRITE, p);
    const auto r = channel_.recvReply(seq, ACK, "WRITE");
    if (!r.empty())
    {
        fail(
            "malformed ACK: payload of " + std::to_string(r.size())
            + " bytes, expected 0"
        );
    }
}


void stepServerClient::bye() noexcept
{
    if (!connected()) return;
    try
    {
        channel_.sendFrame(BYE, {});
    }
    catch (...)
    {}
    close();
}


void stepServerClient::close() noexcept
{
    channel_.stream().close();
}

} // End namespace stepServer
