"""A CPHD 1.0.1 file written with numpy, lxml (sarkit's XML) and sarkit alone, as docs/recording.md §5 describes
it: what another program writing a recording would do. No sarnav code."""

from __future__ import annotations

import lxml.etree as et
import numpy as np
import sarkit.cphd as skcphd

NS = "http://api.nsgreg.nga.mil/schema/cphd/1.0.1"
#: the PVPs written: (name, words), F8 scalars and XYZ triples
PVPS = (("TxTime", 1), ("TxPos", 3), ("TxVel", 3), ("RcvTime", 1), ("RcvPos", 3), ("RcvVel", 3), ("SRPPos", 3),
        ("aFDOP", 1), ("aFRR1", 1), ("aFRR2", 1), ("FX1", 1), ("FX2", 1), ("TOA1", 1), ("TOA2", 1),
        ("TDTropoSRP", 1), ("SC0", 1), ("SCSS", 1))


def _xyz(tag, v, names=("X", "Y", "Z")):
    return f"<{tag}>" + "".join(f"<{n}>{float(x)!r}</{n}>" for n, x in zip(names, v)) + f"</{tag}>"


def write_cphd(path, samples, pvp: dict, fxc: float, fxbw: float, iarp, uiax, uiay, sgn: int = -1,
               fmt: str = "CF16") -> None:
    """``samples`` (P, N) complex, stored as ``fmt`` (CF16 or CF8), ``pvp``: name -> (P,) or (P, 3) float64 arrays
    of PVPS."""
    P, N = samples.shape
    offset, fields = 0, []
    for name, words in PVPS:
        pfmt = "X=F8;Y=F8;Z=F8;" if words == 3 else "F8"
        fields.append(f"<{name}><Offset>{offset}</Offset><Size>{words}</Size><Format>{pfmt}</Format></{name}>")
        offset += words
    xml = f"""<CPHD xmlns="{NS}">
<CollectionID><CollectorName>test</CollectorName><CoreName>test</CoreName><CollectType>MONOSTATIC</CollectType>
<RadarMode><ModeType>SPOTLIGHT</ModeType></RadarMode><Classification>UNCLASSIFIED</Classification>
<ReleaseInfo>UNRESTRICTED</ReleaseInfo></CollectionID>
<Global><DomainType>FX</DomainType><SGN>{sgn}</SGN>
<Timeline><CollectionStart>2026-01-01T00:00:00.000000Z</CollectionStart><TxTime1>{pvp["TxTime"][0]!r}</TxTime1>
<TxTime2>{pvp["TxTime"][-1]!r}</TxTime2></Timeline>
<FxBand><FxMin>{fxc - fxbw / 2!r}</FxMin><FxMax>{fxc + fxbw / 2!r}</FxMax></FxBand>
<TOASwath><TOAMin>{pvp["TOA1"].min()!r}</TOAMin><TOAMax>{pvp["TOA2"].max()!r}</TOAMax></TOASwath></Global>
<SceneCoordinates><EarthModel>WGS_84</EarthModel><IARP>{_xyz("ECF", iarp)}</IARP>
<ReferenceSurface><Planar>{_xyz("uIAX", uiax)}{_xyz("uIAY", uiay)}</Planar></ReferenceSurface>
<ImageArea>{_xyz("X1Y1", (-50.0, -50.0), ("X", "Y"))}{_xyz("X2Y2", (50.0, 50.0), ("X", "Y"))}</ImageArea>
</SceneCoordinates>
<Data><SignalArrayFormat>{fmt}</SignalArrayFormat><NumBytesPVP>{offset * 8}</NumBytesPVP>
<NumCPHDChannels>1</NumCPHDChannels><Channel><Identifier>1</Identifier><NumVectors>{P}</NumVectors>
<NumSamples>{N}</NumSamples><SignalArrayByteOffset>0</SignalArrayByteOffset><PVPArrayByteOffset>0</PVPArrayByteOffset>
</Channel><NumSupportArrays>0</NumSupportArrays></Data>
<Channel><RefChId>1</RefChId><FXFixedCPHD>true</FXFixedCPHD><TOAFixedCPHD>false</TOAFixedCPHD>
<SRPFixedCPHD>true</SRPFixedCPHD><Parameters><Identifier>1</Identifier><RefVectorIndex>0</RefVectorIndex>
<FXFixed>true</FXFixed><TOAFixed>false</TOAFixed><SRPFixed>true</SRPFixed>
<Polarization><TxPol>V</TxPol><RcvPol>V</RcvPol></Polarization><FxC>{fxc!r}</FxC><FxBW>{fxbw!r}</FxBW>
<TOASaved>{pvp["TOA2"].max() - pvp["TOA1"].min()!r}</TOASaved>
<DwellTimes><CODId>1</CODId><DwellId>1</DwellId></DwellTimes></Parameters></Channel>
<PVP>{"".join(fields)}</PVP>
<Dwell><NumCODTimes>1</NumCODTimes><CODTime><Identifier>1</Identifier><CODTimePoly order1="0" order2="0">
<Coef exponent1="0" exponent2="0">0.0</Coef></CODTimePoly></CODTime><NumDwellTimes>1</NumDwellTimes>
<DwellTime><Identifier>1</Identifier><DwellTimePoly order1="0" order2="0"><Coef exponent1="0" exponent2="0">1.0</Coef>
</DwellTimePoly></DwellTime></Dwell>
</CPHD>"""
    tree = et.ElementTree(et.fromstring(xml.encode()))
    dtype = skcphd.get_pvp_dtype(tree)
    arr = np.zeros(P, dtype=dtype)
    for name, _ in PVPS:
        arr[name] = pvp[name]
    with open(path, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=tree)) as w:
        w.write_signal("1", samples.astype(np.complex128 if fmt == "CF16" else np.complex64))
        w.write_pvp("1", arr)
